/*
 * sandmpm — dry sand with the Material Point Method and Drucker–Prager elastoplasticity.
 *
 * The public API of libsandmpm. The method is Klár 2016, "Simulation of Granular Media with the
 * Material Point Method" (thesis, Chapters 2–3, Appendix B); section and equation numbers in the
 * comments refer to it.
 *
 * Conventions: SI units (m, s, kg, Pa), y up, gravity (0, -9.81, 0) by default. Vectors are
 * always passed as 3 components; in 2D the z component is ignored (and reported as 0).
 * Matrices are row-major. The library never prints and never exits; every call that can fail
 * returns an sm_status and leaves a message in sm_world_errmsg().
 *
 * Particle storage: the arrays that sm_world_particles() and sm_world_particle_velocities() hand
 * out stay valid until the next call that steps the world or adds particles (sm_world_step,
 * sm_world_advance, sm_world_seed_shape, sm_world_add_particles, emitters inside a step), which
 * may reallocate them. A step also reorders the particles in storage (by grid block, for speed):
 * index i may hold another particle after a step. Read what you need between steps.
 *
 * A complete program (built and run as the test test_header_example, so it cannot go stale): a
 * sand column collapses on a sticky ground for half a second.
 * @code
 * #include <stdio.h>
 * #include "sandmpm/sandmpm.h"
 *
 * int main(void) {
 *     sm_world_def def = sm_world_def_default(); // dim 3, dx 0.02, domain [0,1]^3, gravity -y
 *     def.dx = 0.025;
 *     sm_world *w;
 *     char err[256];
 *     if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) {
 *         fprintf(stderr, "%s\n", err);
 *         return 2;
 *     }
 *     sm_material_def sand = sm_material_def_sand();   // rho 2200, E 3.537e5, nu 0.3, 35/9/0.2/10
 *     int mat = -1;
 *     sm_collider_def ground = sm_collider_def_default(); // sticky
 *     ground.shape_count = 1;
 *     ground.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
 *     ground.shapes[0].center[1] = 0.1;                  // the plane y = 0.1, solid below
 *     ground.shapes[0].normal[1] = 1;
 *     sm_shape column = sm_shape_default(SM_SHAPE_CYLINDER); // axis along y
 *     column.center[0] = column.center[2] = 0.5;
 *     column.center[1] = 0.25;
 *     column.radius = 0.08;
 *     column.half_height = 0.15;
 *     sm_seed_def seed = sm_seed_def_default();
 *     seed.ppc = 8;                                       // particles per cell
 *     sm_status st = sm_world_add_material(w, &sand, &mat);
 *     seed.material = mat;
 *     if (st == SM_OK) st = sm_world_add_collider(w, &ground, NULL);
 *     if (st == SM_OK) st = sm_world_seed_shape(w, &column, &seed, NULL);
 *     for (int frame = 1; st == SM_OK && frame <= 12; frame++) {
 *         st = sm_world_advance(w, frame / 24.0);         // adaptive steps, lands on the frame time
 *         sm_diagnostics d;
 *         sm_world_diagnostics(w, &d);
 *         printf("t = %.3f s: %zu particles, centre of mass y = %.4f m, kinetic energy %.3g J\n", d.time,
 *                d.particles, d.center_of_mass[1], d.kinetic_energy);
 *     }
 *     if (st != SM_OK) fprintf(stderr, "%s: %s\n", sm_status_string(st), sm_world_errmsg(w));
 *     sm_world_destroy(w);
 *     return st == SM_OK ? 0 : (int)st;
 * }
 * @endcode
 */
#ifndef SANDMPM_H
#define SANDMPM_H

#include <stddef.h>
#include <stdint.h>

#include "sandmpm/config.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Marks the functions of the public API: the only symbols the shared library exports (the
 *  library is compiled with hidden default visibility and SM_BUILDING_LIBRARY defined). */
#if defined(SM_BUILDING_LIBRARY) && (defined(__GNUC__) || defined(__clang__))
#define SM_API __attribute__((visibility("default")))
#else
#define SM_API
#endif

/** Scalar type of the simulation state, chosen at build time (CMake option SM_DOUBLE). */
#if SM_DOUBLE
typedef double sm_real;
#else
typedef float sm_real;
#endif

/** Status codes. The numeric values match the command line's exit codes where they overlap. */
typedef enum sm_status {
    SM_OK = 0,
    SM_ERR_INVALID = 2,   /**< bad input: a definition out of range, an unknown id, ... */
    SM_ERR_NUMERICAL = 3, /**< NaN/Inf or other numerical failure; the step was stopped */
    SM_ERR_IO = 4,        /**< not used by the library itself; reserved for I/O layers */
    SM_ERR_NOMEM = 5      /**< an allocation failed */
} sm_status;

/** Short name of a status ("ok", "invalid input", ...). Never NULL. */
SM_API const char *sm_status_string(sm_status s);

/** Library version, "MAJOR.MINOR.PATCH". */
SM_API const char *sm_version(void);

/** 1 if sm_real is double, 0 if float. */
SM_API int sm_real_is_double(void);

/* ------------------------------------------------------------------------------------------ */
/* World                                                                                        */

/** B-spline interpolation kernel (thesis §3.4.3; the support-3 one is the quadratic). */
typedef enum sm_kernel {
    SM_KERNEL_QUADRATIC = 0, /**< support 3 nodes per axis, APIC D = dx^2/4 */
    SM_KERNEL_CUBIC = 1      /**< support 4 nodes per axis, APIC D = dx^2/3 */
} sm_kernel;

/** Particle/grid transfer scheme (thesis §3.6.1, §3.6.4). */
typedef enum sm_transfer {
    SM_TRANSFER_APIC = 0, /**< affine particle-in-cell (default) */
    SM_TRANSFER_PIC = 1,  /**< plain PIC: dissipative */
    SM_TRANSFER_FLIP = 2  /**< FLIP/PIC blend with flip_ratio */
} sm_transfer;

/** Time integrator of the grid velocities. */
typedef enum sm_integrator {
    SM_INTEGRATOR_EXPLICIT = 0, /**< symplectic Euler (Algorithm 3) */
    SM_INTEGRATOR_IMPLICIT = 1  /**< Newton–GMRES with plasticity inside the force (Algorithms 5, 6, 8) */
} sm_integrator;

/** Collision behaviour of a collider or the domain walls (thesis §3.6.3, Algorithm 7). */
typedef enum sm_collide_mode {
    SM_COLLIDE_STICKY = 0,  /**< no-slip: grid nodes inside, or arriving inside, take the collider's velocity */
    SM_COLLIDE_SLIP = 1,    /**< nodes inside keep their depth, slide tangentially */
    SM_COLLIDE_SEPARATE = 2 /**< nodes may leave the surface but not penetrate (or go deeper) */
} sm_collide_mode;

/** Everything fixed at world creation. Get defaults from sm_world_def_default(). */
typedef struct sm_world_def {
    int dim;                 /**< 2 or 3. Default 3. */
    double dx;               /**< grid spacing, m. Default 0.02. */
    double domain_min[3];    /**< lower corner of the simulated box, m. Default (0,0,0). */
    double domain_max[3];    /**< upper corner, m. Default (1,1,1). Rounded up to whole cells. */
    double gravity[3];       /**< m/s^2. Default (0,-9.81,0). */
    sm_kernel kernel;        /**< default SM_KERNEL_QUADRATIC */
    sm_transfer transfer;    /**< default SM_TRANSFER_APIC */
    double flip_ratio;       /**< FLIP share in [0,1] for SM_TRANSFER_FLIP (3.111). Default 0.95. */
    sm_integrator integrator;/**< default SM_INTEGRATOR_EXPLICIT */
    double cfl;              /**< CFL number in (0,1]: no particle moves more than cfl*dx per step. Default 1 (thesis). */
    double max_dt;           /**< largest time step, s. Default 1e-3. */
    double elastic_cfl;      /**< factor on the elastic-wave bound dt <= elastic_cfl*dx/c, c = sqrt((lambda+2mu)/rho). Default 0.6 (stable to 0.92 and more in every measured case; a block released on an incline creeps more above it: docs/benchmarks.md, "Time-step limit"). 0 disables it. Explicit only: the implicit integrator is not bound by it. */
    sm_collide_mode wall_mode;/**< behaviour of the domain walls. Default SM_COLLIDE_SEPARATE. */
    double wall_friction;    /**< Coulomb coefficient of the domain walls. Default 0. */
    int static_friction_sticks; /**< 1 (default): a grid node in contact with a collider moves in the position
                                     and F update with its post-friction velocity, sticking or slipping: static
                                     friction acts as a constraint like sticky, and a slipping node deforms the
                                     material as its momentum moves. 0: positions and F always use the
                                     pre-friction velocities, exactly as thesis §3.6.5; that lets a block creep
                                     down an incline at about g sin(theta) dt M / m_contact even when
                                     mu > tan(theta), and lets the contact feed a resting block's vibration at
                                     long steps. (Named when it applied to the static regime only.) */
    int particle_projection; /**< 1 (default): a particle that ends a step inside a collider is moved back to
                                  its surface (position only; counted in diagnostics). Collisions are still
                                  resolved on the grid (§3.6.3); this only catches the small residual
                                  penetration the kernel's smoothing allows. 0: off, as in the thesis. */
    double newton_tolerance; /**< implicit: Newton stops when the mass-weighted RMS of the residual (Algorithm 5,
                                  sqrt(sum m |y|^2 / sum m)) is below newton_tolerance * dt; units m/s^2.
                                  Default 1e-3 (about 1e-4 g). */
    int newton_max_iterations;/**< implicit: at most this many Newton steps per time step. Default 20. */
    int gmres_max_iterations; /**< implicit: GMRES iterations per Newton step (the thesis caps it at 15). Default 15. */
    double gmres_tolerance;   /**< implicit: GMRES stops when the residual norm falls below this fraction of
                                  the right-hand side's. Default 1e-2 (inexact Newton). */
    int gmres_preconditioner; /**< implicit: 0 (default) none, as the thesis; 1 block Jacobi (per grid node the
                                  inverse of the symmetric part of the Newton system's d x d diagonal block, on
                                  the right: the same residual is minimised). Measured: 9-20% fewer GMRES
                                  iterations on some scenes, 15% more on others (docs/benchmarks.md). */
    int threads;             /**< threads of a step. 0 (default): chosen per step by the library between one
                                  thread and OpenMP's default count (omp_get_max_threads: the cores, or
                                  OMP_NUM_THREADS), whichever steps faster on this machine now (small
                                  scenes, a machine shared with busy processes); it times the steps and
                                  probes the other choice now and then. Results do not depend on it.
                                  The step runs on a pool of worker threads that belongs to the thread
                                  calling the library (made on its first step of more than one thread,
                                  ended when that thread ends; the workers block signals and sleep
                                  about 0.35 ms after their last work). */
    size_t max_particles;    /**< refuse to grow beyond this many particles; 0 = no limit. */
    double contact_gap;      /**< the contact gate, in cells (dx): a separating collider (and separating domain
                                  walls) acts on a grid node only if a particle whose stencil holds the node
                                  lies within contact_gap dx of it at the end of the step as it moves now. A
                                  node's mass reaches 1.5 dx (quadratic) or 2 dx (cubic) beyond the
                                  particles, so without the gate material is stopped up to that far short
                                  of a wall. Default INFINITY: no gate (every node with mass meets every
                                  collider, as the thesis). 0.35 (above the 0.25 dx between a resting
                                  layer of 4 (2D) or 8 (3D) particles per cell and the surface) brings every
                                  case of the incline benchmark within 1e-3 at max_dt 2e-5 s, but at the
                                  elastic time step a block resting on a grid-aligned plane at mu 0.7 slid
                                  farther with it than without (docs/validation.md, section 6). Must be > 0. */
} sm_world_def;

/** Defaults as documented on each field. */
SM_API sm_world_def sm_world_def_default(void);

/** Most cells along one axis of the domain (the grid's block keys hold 21 bits per axis). */
#define SM_MAX_CELLS_PER_AXIS 4194304

/** Checks a definition without creating a world: SM_OK, or SM_ERR_INVALID with the reason in err
 *  (if not NULL, up to errlen bytes), e.g. "dx: must be > 0, got -1". sm_world_create applies the
 *  same checks; scene loaders call this to report a bad definition before building anything. */
SM_API sm_status sm_world_def_check(const sm_world_def *def, char *err, size_t errlen);

typedef struct sm_world sm_world;

/** Creates a world. On failure *out is NULL and the status says why (no message object exists
 *  yet, so the reason is also written to err, if err is not NULL, up to errlen bytes). */
SM_API sm_status sm_world_create(const sm_world_def *def, sm_world **out, char *err, size_t errlen);

/** Destroys a world. Accepts NULL. */
SM_API void sm_world_destroy(sm_world *w);

/** The message of the last failed call on this world ("" if none). */
SM_API const char *sm_world_errmsg(const sm_world *w);

/** Changes the number of threads used by later steps (0: the library chooses, as sm_world_def.threads). */
SM_API void sm_world_set_threads(sm_world *w, int threads);

/** The definition the world was created with (domain rounded to whole cells). */
SM_API const sm_world_def *sm_world_get_def(const sm_world *w);

/** Grid nodes per axis (x, y, z; z = 1 in 2D). */
SM_API void sm_world_grid_size(const sm_world *w, int n[3]);

/* ------------------------------------------------------------------------------------------ */
/* Materials                                                                                    */

typedef enum sm_material_kind {
    SM_MATERIAL_SAND = 0,   /**< Hencky St. Venant–Kirchhoff + Drucker–Prager plasticity */
    SM_MATERIAL_ELASTIC = 1 /**< the same energy, no plasticity */
} sm_material_kind;

/** How the Drucker–Prager cone ||dev tau|| + alpha tr tau <= 0 is fitted to a Mohr–Coulomb friction
 *  angle phi_F, i.e. the function alpha(phi_F, d). The plastic flow of the return mapping is
 *  deviatoric (volume-preserving), so in steady simple shear the stress ratio on the shear plane is
 *  mu_eff = 3 alpha / sqrt(2) in 3D and sqrt(2) alpha in 2D (d = 2 traces), whatever the fit
 *  (derivation in docs/validation.md, "What the friction angle means"). */
typedef enum sm_cone_fit {
    SM_CONE_TRIAXIAL_COMPRESSION = 0, /**< the thesis (3.80), default: alpha = sqrt(2/3) 2 sin(phi)/(3 - sin(phi)),
                                           the cone through Mohr–Coulomb's compression meridian (circumscribed);
                                           the same alpha in 2D. mu_eff(30 deg) = 0.693 in 3D, 0.462 in 2D. */
    SM_CONE_PLANE_STRAIN = 1,         /**< Mohr–Coulomb in plane strain with this (non-dilatant) flow:
                                           mu_eff = sin(phi); alpha = sqrt(2) sin(phi)/3 in 3D, sin(phi)/sqrt(2) in 2D
                                           (in 2D the cone is then exactly Mohr–Coulomb in the plane). */
    SM_CONE_INSCRIBED = 2,            /**< the cone inscribed in the Mohr–Coulomb pyramid:
                                           alpha = sqrt(2/3) sin(phi)/sqrt(3 + sin^2(phi)); the same alpha in 2D. */
    SM_CONE_SIMPLE_SHEAR = 3          /**< steady simple shear flows at tau/sigma = tan(phi), the granular-physics
                                           friction coefficient (repose angle of a flowing layer = phi):
                                           alpha = sqrt(2) tan(phi)/3 in 3D, tan(phi)/sqrt(2) in 2D. */
} sm_cone_fit;

/** A material. Angles are in degrees, as in the thesis's Table 4.2. */
typedef struct sm_material_def {
    sm_material_kind kind;
    double density;          /**< rho, kg/m^3 (> 0) */
    double youngs_modulus;   /**< E, Pa (> 0) */
    double poisson_ratio;    /**< nu, in (-1, 0.5) */
    int hardening;           /**< sand: 1 = hardening with h0..h3 (3.78-3.80); 0 = fixed friction_angle */
    double friction_angle;   /**< sand without hardening: phi_F in degrees, [0, 90) */
    double h0, h1, h2, h3;   /**< hardening: phi_F = h0 + (h1 q - h3) exp(-h2 q); h0,h1,h3 degrees, h2 dimensionless.
                                  All >= 0, h0 > h3, h0 < 90, and phi_F < 90 for every q >= 0: with h1 > 0 the peak
                                  h0 + (h1/h2) exp(-(1 + h2 h3/h1)) at q = 1/h2 + h3/h1 must be < 90 (so h2 > 0). */
    sm_cone_fit cone_fit;    /**< sand: how alpha follows from phi_F (fixed or hardening). Default (0)
                                  SM_CONE_TRIAXIAL_COMPRESSION, the thesis. */
} sm_material_def;

/** Sand as in most thesis scenes: rho 2200, E 3.537e5, nu 0.3, hardening 35/9/0.2/10. */
SM_API sm_material_def sm_material_def_sand(void);
/** An elastic solid: rho 1000, E 1e5, nu 0.3. */
SM_API sm_material_def sm_material_def_elastic(void);

/** Checks a material definition without a world: SM_OK, or SM_ERR_INVALID with the reason in err
 *  (if not NULL), e.g. "nu: must be in (-1, 0.5), got 0.7". sm_world_add_material applies it. */
SM_API sm_status sm_material_def_check(const sm_material_def *m, char *err, size_t errlen);

/** Adds a material. Returns SM_OK and its id in *id (if id is not NULL), or SM_ERR_INVALID (bad
 *  definition) / SM_ERR_NOMEM with a message and *id = -1. */
SM_API sm_status sm_world_add_material(sm_world *w, const sm_material_def *m, int *id);

/** Friction angle in degrees for hardening state q (3.79). */
SM_API double sm_hardening_friction_angle(const sm_material_def *m, double q);
/** Drucker–Prager alpha for a friction angle in degrees (3.80): sqrt(2/3) 2 sin(phi)/(3 - sin(phi)). */
SM_API double sm_alpha_from_friction_angle(double degrees);
/** Drucker–Prager alpha for a friction angle in degrees, a cone fit and a dimension (2 or 3); what
 *  the world uses. SM_CONE_TRIAXIAL_COMPRESSION gives sm_alpha_from_friction_angle. NaN for an
 *  unknown fit or dim. */
SM_API double sm_cone_alpha(double degrees, sm_cone_fit fit, int dim);
/** Effective friction coefficient of steady simple shear, tau/sigma_n on the shear plane, for a
 *  cone alpha in dimension dim: 3 alpha/sqrt(2) (3D), sqrt(2) alpha (2D). NaN for another dim. */
SM_API double sm_effective_friction(double alpha, int dim);
/** The friction angle phi_F (degrees) that gives steady simple shear the effective friction mu
 *  (>= 0) with the cone fit `fit` in dimension dim: the inverse of sm_effective_friction(
 *  sm_cone_alpha(phi, fit, dim), dim). A target repose angle theta is mu = tan(theta). NaN if no
 *  phi_F in [0, 90) reaches mu with that fit (e.g. mu >= 1 with SM_CONE_PLANE_STRAIN). */
SM_API double sm_friction_angle_for_effective_friction(double mu, sm_cone_fit fit, int dim);

/* ------------------------------------------------------------------------------------------ */
/* Shapes: signed distance functions, negative inside.                                          */

/** Mesh fields: the signed distance field of a triangle mesh (3D) or of a closed polyline in the
 *  xy plane (2D), exact on a narrow band of nodes around the surface (a bounding volume hierarchy
 *  over the triangles) and stored sparsely in bricks, interpolated trilinearly (docs/mesh-fields.md).
 *  Beyond the band the value is clamped to +-band with the right sign. The library never reads
 *  files: vertices and elements come from the caller (the program reads them with assimp).
 *  Reference counted: create gives one reference; a collider (sm_world_add_collider) holds its own
 *  until the world is destroyed, seeding only uses the field during the call. Retain and release
 *  from one thread at a time. */
typedef struct sm_mesh_field sm_mesh_field;

/** How the inside of a mesh is told from the outside. */
typedef enum sm_mesh_sign {
    /** Generalised winding number w >= 1/2 is inside: closed or nearly closed surfaces, overlapping
     *  closed parts, non-manifold edges. A surface whose normals all point inwards (negative signed
     *  volume) is a container: solid outside, free inside. */
    SM_MESH_SIGN_WINDING = 0,
    /** The side of the nearest feature's angle-weighted pseudo-normal: an open surface (terrain, a
     *  sheet) is a one-sided collider, solid behind its normals. */
    SM_MESH_SIGN_ONE_SIDED = 1
} sm_mesh_sign;

typedef struct sm_mesh_field_def {
    int dim;                  /**< 3: triangles; 2: segments of an outline in the xy plane */
    const double *vertices;   /**< vertex_count x 3 doubles (z ignored in 2D), m, in the mesh's frame */
    size_t vertex_count;
    const uint32_t *elements; /**< element_count x dim vertex indices (triangles / segments) */
    size_t element_count;
    double spacing;           /**< node spacing h of the field (the simulation dx or finer), > 0 */
    double band;              /**< half width of the stored band (>= spacing) */
    sm_mesh_sign sign;
    int threads;              /**< OpenMP threads for the build; 0: the default. The field does not depend on it. */
} sm_mesh_field_def;

/** Winding sign, everything else zero. */
SM_API sm_mesh_field_def sm_mesh_field_def_default(void);

/** What a field holds and what its build cost. */
typedef struct sm_mesh_field_stats {
    int dim;
    size_t elements;         /**< triangles (3D) / segments (2D) */
    size_t vertices;
    double spacing, band;
    int table[3];            /**< bricks (8 cells a side) per axis of the coarse table (1 in z for 2D) */
    size_t candidate_bricks; /**< bricks whose centre is within band + half diagonal of the surface */
    size_t bricks;           /**< bricks stored: those with a node within the band */
    size_t band_nodes;       /**< stored nodes with |phi| < band */
    size_t bytes;            /**< memory of the field */
    double lipschitz;        /**< bound on |grad phi| of the interpolant (>= 1; up to sqrt(dim) at sharp corners) */
    double volume;           /**< signed volume (3D) / area (2D) enclosed; < 0: inside out */
    int container;           /**< 1: winding rule with a negative volume: solid outside the surface */
    double seconds;          /**< wall time of the build (0 for a field read back from bytes) */
    double lo[3], hi[3];     /**< the field's table box in the mesh frame (the surface grown by about
                                  the band): a solid lies inside it; beyond it phi = +band (-band for
                                  a container) */
} sm_mesh_field_stats;

/** Builds a field. SM_OK and *out (one reference), or SM_ERR_INVALID (no elements, an index out
 *  of range, a non-finite vertex, spacing or band out of range, a table too large for the spacing)
 *  / SM_ERR_NOMEM with the reason in err (if not NULL) and *out = NULL. */
SM_API sm_status sm_mesh_field_create(const sm_mesh_field_def *def, sm_mesh_field **out, char *err, size_t errlen);
/** An animated field (issue 15): frame_count >= 2 frames of one mesh (the same vertex count and
 *  element array, vertices moved), shown at fps frames per second from t = 0, held before the
 *  first and after the last. At time t between frames f and f+1 (fraction s), phi = (1-s) phi_f
 *  + s phi_{f+1} and the surface's velocity is (1-s) v_f + s v_{f+1}, v_k being the vertex
 *  velocities (x^{f+1} - x^f) fps interpolated with the barycentric coordinates of the closest
 *  point on frame k's triangles (0 before the first frame and after the last). A collider with
 *  such a shape pushes sand with that velocity (plus its own rigid motion); seeding, emitters and
 *  sm_mesh_field_distance see frame 0. SM_ERR_INVALID names the frame whose topology differs or
 *  whose field fails; every frame is built (frames[i].threads) and kept. One reference. */
SM_API sm_status sm_mesh_field_create_animated(const sm_mesh_field_def *frames, int frame_count, double fps,
                                               sm_mesh_field **out, char *err, size_t errlen);
/** Frames of an animated field (1 for a static one) and its frames per second (0 if static). */
SM_API int sm_mesh_field_frame_count(const sm_mesh_field *f, double *fps);
/** Adds a reference; returns f. */
SM_API sm_mesh_field *sm_mesh_field_retain(sm_mesh_field *f);
/** Drops a reference; the last one frees the field. NULL is fine. */
SM_API void sm_mesh_field_release(sm_mesh_field *f);
SM_API const sm_mesh_field_stats *sm_mesh_field_get_stats(const sm_mesh_field *f);
/** Signed distance at x in the mesh's own frame, unit normal in grad (if not NULL). */
SM_API double sm_mesh_field_distance(const sm_mesh_field *f, const double x[3], double grad[3]);
/** Serialisation for a cache file: writes at most cap bytes to buf (buf may be NULL with cap 0)
 *  and returns the size needed. The bytes depend on the definition alone (not on threads). */
SM_API size_t sm_mesh_field_serialize(const sm_mesh_field *f, void *buf, size_t cap);
/** A field from serialised bytes (one reference). SM_ERR_INVALID with a reason (bad magic,
 *  version or byte order, truncated, checksum mismatch) or SM_ERR_NOMEM. */
SM_API sm_status sm_mesh_field_deserialize(const void *buf, size_t n, sm_mesh_field **out, char *err, size_t errlen);

typedef enum sm_shape_kind {
    SM_SHAPE_HALFSPACE = 0, /**< solid below the plane through `center` with outward `normal` */
    SM_SHAPE_BOX = 1,       /**< box with `half_extent`, rotated by `rotation` about `center` */
    SM_SHAPE_SPHERE = 2,    /**< ball (disk in 2D) of `radius` */
    SM_SHAPE_CYLINDER = 3,  /**< capped cylinder of `radius`, axis = local y, `half_height` */
    SM_SHAPE_MESH = 4       /**< the field `mesh` (its own frame placed by `center` and `rotation`) */
} sm_shape_kind;

/** A primitive shape. In 2D, z components are ignored and rotation is about z only. */
typedef struct sm_shape {
    sm_shape_kind kind;
    double center[3];       /**< m: a point on the plane, or the centre of the shape */
    double normal[3];       /**< half-space outward normal (need not be unit) */
    double half_extent[3];  /**< box half sizes, m */
    double radius;          /**< sphere, cylinder, m */
    double half_height;     /**< cylinder half length along its axis, m */
    double rotation[4];     /**< unit quaternion (w,x,y,z): local -> shape frame. Default identity. */
    int inside_out;         /**< 1: the complement (a container: solid outside, free inside) */
    const sm_mesh_field *mesh; /**< SM_SHAPE_MESH: the field, of the world's dimension (not owned:
                                    colliders retain it, seeding uses it during the call) */
} sm_shape;

/** A shape with identity rotation and everything else zero. */
SM_API sm_shape sm_shape_default(sm_shape_kind kind);

/** Signed distance of a shape at point x (3 components), with its unit gradient if grad != NULL. */
SM_API double sm_shape_distance(const sm_shape *s, int dim, const double x[3], double grad[3]);

/* ------------------------------------------------------------------------------------------ */
/* Particles                                                                                    */

typedef enum sm_seed_method {
    SM_SEED_JITTERED = 0, /**< a lattice of ppc points per cell, each moved randomly within its sub-cell */
    SM_SEED_POISSON = 1   /**< Poisson disk (Bridson) with a radius giving about ppc per cell */
} sm_seed_method;

/** How to fill a shape with particles. */
typedef struct sm_seed_def {
    int material;           /**< id from sm_world_add_material */
    double ppc;             /**< particles per cell (> 0); V0 = dx^d/ppc, mass = rho V0 */
    sm_seed_method method;  /**< default SM_SEED_JITTERED */
    uint64_t seed;          /**< RNG seed: same seed, same particles */
    double velocity[3];     /**< initial velocity, m/s */
    double angular_velocity[3]; /**< initial spin about the shape's seeding centroid, rad/s */
    const sm_shape *clip;   /**< optional second shape: only points inside both are kept */
} sm_seed_def;

SM_API sm_seed_def sm_seed_def_default(void);

/** Fills a shape (its interior, clipped to the domain) with particles. Returns the number added
 *  in *added (if not NULL). A half-space or inside-out shape fills the whole domain part it covers. */
SM_API sm_status sm_world_seed_shape(sm_world *w, const sm_shape *shape, const sm_seed_def *seed, size_t *added);

/** Adds n particles at given positions (3n values) with given velocities (3n values, or NULL for
 *  rest), undeformed, each with volume V0 = dx^d/ppc. Used by emitters and tests. */
SM_API sm_status sm_world_add_particles(sm_world *w, size_t n, const double *positions, const double *velocities,
                                 int material, double ppc);

/** Read-only view of the particle arrays (structure of arrays, n particles, d = dim). */
typedef struct sm_particles_view {
    size_t n;
    int dim;
    const double *x;      /**< positions, n*d (double in both builds: slow motion is never lost to
                               the rounding of a float position) */
    const sm_real *v;     /**< velocities, n*d */
    const sm_real *B;     /**< APIC affine momentum matrices, n*d*d, row-major */
    const sm_real *F;     /**< elastic deformation gradients F^E, n*d*d, row-major */
    const sm_real *vol0;  /**< initial volume V0, n */
    const sm_real *q;     /**< hardening state, n */
    const sm_real *alpha; /**< Drucker–Prager alpha, n */
    const uint16_t *material; /**< material id, n */
    const uint32_t *id;   /**< stable particle id, n: 0, 1, 2, ... in order of insertion (seeding,
                               sm_world_add_particles, emitters); kept through the step's reorders
                               and through checkpoints */
} sm_particles_view;

SM_API void sm_world_particles(const sm_world *w, sm_particles_view *out);

/** Mass of particle i in kg (its material's density times vol0; not stored per particle);
 *  0 if i is out of range. */
SM_API double sm_world_particle_mass(const sm_world *w, size_t i);

/** Writable velocity access (e.g. to give an object a kick); n*d values. */
SM_API sm_real *sm_world_particle_velocities(sm_world *w);

/** Friction angle in degrees of particle i (from its material and q). */
SM_API double sm_world_particle_friction_angle(const sm_world *w, size_t i);

/** Estimated volume (m^3, or m^2 in 2D) of shape ∩ clip ∩ [lo, hi] by sampling a 64^d lattice of
 *  its bounding box; used to estimate particle counts (volume * ppc / dx^d) before seeding. */
SM_API double sm_shape_volume_estimate(const sm_shape *shape, const sm_shape *clip, int dim, const double lo[3],
                                const double hi[3]);

/** Bytes per particle held by the library (state, per-step scratch and the sparse grid's share),
 *  for memory estimates. */
SM_API size_t sm_particle_bytes(int dim);

/** Bytes a world created from def needs besides what its particles cost (the grid is sparse and
 *  grows with the particles; see sm_particle_bytes); 0 if def is invalid. */
SM_API size_t sm_world_def_grid_bytes(const sm_world_def *def);

/** Bytes of heap memory the world holds now: particle storage (by capacity), the grid's live
 *  blocks and lookup tables, sort and step scratch, colliders, emitters, implicit workspace. */
SM_API size_t sm_world_memory_bytes(const sm_world *w);

/** Number of heap allocations (malloc, calloc, realloc) the library has made in this process,
 *  all worlds together. Constant across steps once a simulation has reached its steady state. */
SM_API uint64_t sm_allocation_count(void);

/* ------------------------------------------------------------------------------------------ */
/* Emitters                                                                                     */

/** A particle source: emits particles uniformly at random inside `shape` at a mass flow rate,
 *  between `start` and `stop` (s). Each particle has V0 = dx^d/ppc, mass rho V0, the given
 *  velocity, and is undeformed. Emission is deterministic (counter-based RNG from `seed`). */
typedef struct sm_emitter_def {
    sm_shape shape;       /**< where particles appear (must be inside the usable domain): a sphere,
                               box, cylinder or closed mesh field (not inside out, not a container;
                               the emitter keeps a reference on the field) */
    int material;         /**< material id */
    double ppc;           /**< sets the particle volume, V0 = dx^d/ppc (> 0) */
    double velocity[3];   /**< initial velocity, m/s */
    double rate;          /**< mass flow rate, kg/s (kg/(m s) in 2D) (> 0) */
    double start, stop;   /**< active time interval, s (stop > start) */
    uint64_t seed;        /**< RNG seed */
} sm_emitter_def;

SM_API sm_emitter_def sm_emitter_def_default(void);

/** Adds an emitter. Returns SM_OK and its id in *id (if not NULL), or a status with a message and
 *  *id = -1. Emitters run at the end of each
 *  step (after plasticity), adding the mass that flowed during the step (fractions carry over). */
SM_API sm_status sm_world_add_emitter(sm_world *w, const sm_emitter_def *e, int *id);

/** Total mass emitted so far by emitter id (kg). */
SM_API double sm_world_emitted_mass(const sm_world *w, int id);

/* ------------------------------------------------------------------------------------------ */
/* Colliders                                                                                    */

#define SM_MAX_COLLIDER_SHAPES 16

/** Rigid pose of a collider at a time: position of its origin and orientation. */
typedef struct sm_pose {
    double position[3];     /**< m */
    double rotation[4];     /**< unit quaternion (w,x,y,z) */
} sm_pose;

/** Scripted motion: fills the pose at time t. Called once per step per collider (never per node). */
typedef void (*sm_motion_fn)(void *user, double t, sm_pose *pose);

/** A rigid collider: a union of shapes in its own frame, or the complement of that union. */
typedef struct sm_collider_def {
    int shape_count;                          /**< 1..SM_MAX_COLLIDER_SHAPES */
    sm_shape shapes[SM_MAX_COLLIDER_SHAPES];  /**< in the collider's frame */
    int inside_out;                           /**< 1: complement of the union (a container) */
    sm_collide_mode mode;
    double friction;                          /**< Coulomb coefficient mu >= 0 */
    sm_pose pose;                             /**< pose at t = 0 (identity = shapes as given) */
    double velocity[3];                       /**< constant linear velocity of the origin, m/s */
    double angular_velocity[3];               /**< constant angular velocity about the origin, rad/s */
    sm_motion_fn motion;                      /**< if set, overrides velocity/angular_velocity */
    void *motion_user;
} sm_collider_def;

SM_API sm_collider_def sm_collider_def_default(void);

/** Checks a collider definition for a world of dimension dim (2 or 3) without a world: SM_OK, or
 *  SM_ERR_INVALID with the reason in err (if not NULL). sm_world_add_collider applies it. */
SM_API sm_status sm_collider_def_check(const sm_collider_def *c, int dim, char *err, size_t errlen);

/** Adds a collider. Returns SM_OK and its id in *id (if not NULL), or SM_ERR_INVALID / SM_ERR_NOMEM
 *  with a message and *id = -1. */
SM_API sm_status sm_world_add_collider(sm_world *w, const sm_collider_def *c, int *id);

/** Signed distance of collider id at point x at the current time (gradient optional). */
SM_API double sm_world_collider_distance(const sm_world *w, int id, const double x[3], double grad[3]);

/** Current pose of collider id. */
SM_API void sm_world_collider_pose(const sm_world *w, int id, sm_pose *pose);

/** Number of colliders, and the definition collider id was added with (NULL if out of range). */
SM_API int sm_world_collider_count(const sm_world *w);
SM_API const sm_collider_def *sm_world_collider_def(const sm_world *w, int id);

/* ------------------------------------------------------------------------------------------ */
/* Time stepping                                                                                */

/** Stages of one step, timed into sm_diagnostics.stage_seconds. */
typedef enum sm_stage {
    SM_STAGE_DT = 0,     /**< choosing dt (max particle speed) */
    SM_STAGE_SORT,       /**< binning particles by grid block, activating and clearing grid blocks */
    SM_STAGE_P2G,        /**< particle to grid: mass, momentum, internal force */
    SM_STAGE_GRID,       /**< grid velocity update, colliders, friction, domain walls */
    SM_STAGE_G2P,        /**< grid to particle: velocity, B, position, F */
    SM_STAGE_PLASTICITY, /**< SVD, return mapping, hardening, next step's stress */
    SM_STAGE_CHECKS,     /**< NaN/Inf and CFL checks of particle and grid state */
    SM_STAGE_EXCHANGE,   /**< distributed runs: particles migrating and ghosts between ranks */
    SM_STAGE_COUNT
} sm_stage;

/** Name of a stage ("p2g", ...). */
SM_API const char *sm_stage_name(sm_stage s);

/** The next time step the world would take, capped so it does not pass t_end (s). After a step
 *  that sm_world_step refused (the CFL check, an implicit solve that did not converge), at most
 *  half the refused dt (until a step is taken). Implicit: also at most twice the last dt after a
 *  Newton solve of at most 3 iterations, 1.25 times it after at most 8, the last dt after more. */
SM_API double sm_world_next_dt(sm_world *w, double t_end);

/** One step of size dt (> 0, s). Returns SM_ERR_NUMERICAL with a message naming the step and
 *  particle if the state becomes NaN/Inf; the state is then the last good one and the world has
 *  stopped (every later step fails). A dt in which a particle would move more than one cell (the
 *  CFL bound, with a relative slack of 1e-5 on the squared speed so that sm_world_next_dt's own
 *  choice at cfl = 1 passes) is refused before anything moves: SM_ERR_NUMERICAL with a message
 *  naming the particle, the world unchanged and still usable; retry with a smaller dt (or with
 *  sm_world_next_dt, which then returns at most half the refused dt). The implicit integrator
 *  refuses a dt above max_dt / 1024 in the same way (same status, world unchanged) when Newton
 *  does not converge in newton_max_iterations; at or below it the step is taken and counted in
 *  sm_diagnostics.newton_unconverged. sm_world_advance retries both refusals itself; a caller
 *  of sm_world_step tells a refusal from a failure with sm_world_step_refused. */
SM_API sm_status sm_world_step(sm_world *w, double dt);

/** 1 if the last sm_world_step was refused (the CFL check or an unconverged implicit solve) with
 *  the world unchanged: retry with sm_world_next_dt, which returns at most half the refused dt.
 *  0 after a step taken, a failure, or before any step. */
SM_API int sm_world_step_refused(const sm_world *w);

/** Adaptive steps until the world's time equals t_end exactly. A step refused by the CFL check or
 *  by an unconverged implicit solve (see sm_world_step) is retried with half the dt, up to 60
 *  times in a row. */
SM_API sm_status sm_world_advance(sm_world *w, double t_end);

/** An interrupt for sm_world_advance: before each step it takes (not between the retries of a
 *  refused one) it calls poll(user), and when that returns non-zero it returns SM_OK at once,
 *  the world at the end of its last step, before t_end, with sm_world_interrupted(w) = 1. The
 *  world is whole there: it may be saved (a checkpoint resumes bitwise, also mid-way to t_end)
 *  or advanced further. In a distributed world (sandmpm_mpi.h) set it on every rank alike (the
 *  check is collective): poll runs on every rank before every step and the answers are agreed,
 *  so any rank's stops all at the same step. NULL removes it. Not saved in checkpoints. poll must be cheap (a signal flag, a clock). */
SM_API void sm_world_set_interrupt(sm_world *w, int (*poll)(void *user), void *user);

/** 1 if the last sm_world_advance returned early for its interrupt (sm_world_set_interrupt). */
SM_API int sm_world_interrupted(const sm_world *w);

/** Simulated time, s. */
SM_API double sm_world_time(const sm_world *w);

/* ------------------------------------------------------------------------------------------ */
/* Diagnostics                                                                                  */

typedef struct sm_diagnostics {
    size_t particles;
    double total_mass;            /**< kg */
    double momentum[3];           /**< kg m/s */
    double angular_momentum[3];   /**< about the origin, kg m^2/s; APIC includes the B term. In 2D only z. */
    double kinetic_energy;        /**< J, (1/2) sum m v^2 */
    double elastic_energy;        /**< J, sum V0 psi(F^E) */
    double max_speed;             /**< m/s */
    double center_of_mass[3];     /**< m */
    uint64_t steps;               /**< steps taken since creation */
    double time;                  /**< s */
    double last_dt;               /**< s */
    double min_dt, max_dt;        /**< smallest and largest step since the last sm_world_reset_step_stats */
    double stage_seconds[SM_STAGE_COUNT]; /**< wall time per stage since creation */
    uint64_t clamped_particles;   /**< particle-steps pushed back inside the domain by the safety clamp */
    uint64_t projected_particles; /**< particle-steps moved out of a collider (particle_projection) */
    uint64_t newton_iterations;   /**< implicit: Newton steps since creation */
    uint64_t gmres_iterations;    /**< implicit: GMRES iterations since creation */
    int last_newton_iterations;   /**< implicit: Newton steps of the last time step */
    double last_newton_residual;  /**< implicit: final RMS residual of the last step divided by dt, m/s^2 */
    uint64_t newton_unconverged;  /**< implicit: time steps that hit newton_max_iterations (taken as they were: dt was at most max_dt / 1024) */
    uint64_t newton_rejected;     /**< implicit: time steps refused because Newton did not converge, retried at half the dt */
    uint64_t newton_floor_stops;  /**< implicit: solves that stopped at the precision's rounding floor, above newton_tolerance */
    int threads;                  /**< threads of the next step (def.threads, or the library's choice
                                       when def.threads = 0) */
    uint64_t thread_switches;     /**< def.threads = 0: times the library changed its choice */
} sm_diagnostics;

/** Computes the diagnostics (O(n)). */
SM_API void sm_world_diagnostics(const sm_world *w, sm_diagnostics *out);

/** Resets min_dt/max_dt tracking (e.g. at each frame). */
SM_API void sm_world_reset_step_stats(sm_world *w);

/** A 64-bit hash of all particle state (bitwise), for determinism checks; in storage order. */
SM_API uint64_t sm_world_state_hash(const sm_world *w);

/** The same state hash with the particles taken in ascending id: equal for any storage order,
 * thread count and, in a distributed world (sandmpm_mpi.h), any number of ranks. In a
 * distributed world it is collective (every rank calls it; every rank gets the hash of all the
 * ranks' particles). 0 when out of memory. */
SM_API uint64_t sm_world_id_hash(const sm_world *w);

/* ------------------------------------------------------------------------------------------ */
/* Checkpoints (docs/checkpoints.md)                                                            */

/** Receives the next len bytes of a checkpoint; returns 0 on success, non-zero to abort the save
 *  (sm_world_save then returns SM_ERR_IO). The embedder picks the storage: a file, memory, ... */
typedef int (*sm_write_fn)(void *user, const void *data, size_t len);

/** Receives len bytes of a checkpoint that belong at byte `offset` of the stream (a rank's share
 *  of one written by several: sm_id_slice_save in sandmpm_mpi.h); 0 on success. */
typedef int (*sm_pwrite_fn)(void *user, uint64_t offset, const void *data, size_t len);

/** Reads len bytes at byte `offset` of a checkpoint into data (a file's pread, a part of memory);
 *  0 on success, non-zero on a read error (the restore then returns SM_ERR_IO). */
typedef int (*sm_pread_fn)(void *user, uint64_t offset, void *data, size_t len);

/** Writes the world's complete state through write: a versioned header (magic "SANDMPMC", format
 *  version, precision, dimension), the world definition, materials, colliders (definitions and
 *  their motion state), emitters (definitions, owed mass, emitted count: their whole RNG state),
 *  the clock, the time-step controller, the statistics and every particle field. A world loaded
 *  from it (sm_world_load, or sm_world_restore into a world built the same way) continues
 *  bitwise identically to this one, whatever the thread count. Motion functions cannot be
 *  saved: only whether a collider had one. Returns SM_OK or SM_ERR_IO (write failed). No
 *  checksum inside: a file layer adds one (the CLI does). */
SM_API sm_status sm_world_save(const sm_world *w, sm_write_fn write, void *user);

/** Creates a world from a checkpoint held in memory (len bytes). Colliders come back without
 *  motion functions (use sm_world_restore on a world built with them instead). Rejects a wrong
 *  magic, version, precision (float/double build), byte order, an invalid definition, a
 *  truncated or inconsistent stream with SM_ERR_INVALID and the reason in err; never reads
 *  outside [data, data + len). */
SM_API sm_status sm_world_load(const void *data, size_t len, sm_world **out, char *err, size_t errlen);

/** Replaces the evolving state of w (particles, clock, controller, statistics, collider poses,
 *  emitter counters) by a checkpoint's. w must have been built like the saved world (same
 *  definition, materials, colliders, emitters, in the same order: the counts, dim, dx,
 *  integrator, transfer and kernel are checked); w keeps its own definitions, so motion
 *  functions stay attached. On failure w is unchanged and the message says why. */
SM_API sm_status sm_world_restore(sm_world *w, const void *data, size_t len);

/** sm_world_restore from a checkpoint of len bytes read at offsets through read (e.g. from its
 *  file), so the stream never has to be in memory whole: the memory needed is the restored world's
 *  plus a few MiB. A failed read is SM_ERR_IO. */
SM_API sm_status sm_world_restore_read(sm_world *w, sm_pread_fn read, void *user, uint64_t len);

#ifdef __cplusplus
}
#endif
#endif
