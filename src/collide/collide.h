/* Level-set colliders (thesis §3.6.3, Algorithm 7).
 *
 * A collider is a union of signed-distance shapes (half-space, box, sphere, capped cylinder, mesh
 * field; each optionally inside-out), optionally complemented as a whole, moving rigidly.
 * phi < 0 is inside the solid. Collision acts on grid node velocities, never on particles.
 *
 * Per step the world calls sm_collider_begin_step (pose at t^n and t^{n+1}, rigid velocity over
 * the step), then for every grid node with mass sm_collide_node (GRID_COLLISIONS: sticky / slip /
 * separate projection of v* -> v-bar, recording contacts) and sm_friction_node (FRICTION: Coulomb
 * friction from the collision impulse, relative to the collider's velocity -> v-tilde), then
 * sm_collider_end_step. Everything here is in double; grid values are converted at the call. */
#ifndef SM_COLLIDE_H
#define SM_COLLIDE_H

#include "core/common.h"

typedef struct sm_collider {
    sm_collider_def def;   /* copy of the definition (shapes in the collider's frame) */
    double t0, dt;         /* current step: [t0, t0 + dt] */
    sm_pose pose0, pose1;  /* pose at t^n and t^{n+1} */
    double R0[9], R1[9];   /* rotation matrices of pose0, pose1 (row-major, local -> world) */
    double v[3];           /* linear velocity of the origin over the step, m/s */
    double w[3];           /* angular velocity over the step, rad/s (world frame) */
    double lip;            /* Lipschitz constant of phi: 1 for analytic shapes, the largest
                              stats.lipschitz of its mesh shapes otherwise (for the culling bounds) */
    int animated;          /* 1: a shape is an animated mesh: phi depends on time (t0, t0 + dt) and
                              the velocity adds the mesh's deformation velocity (mesh_anim.c) */
    int halfspace;         /* 1: one half-space shape with the identity rotation (a ground, a wall):
                              sm_collider_phi takes its short path */
    double hs_g[2][3];     /* that shape's unit normal in 2D ([0]: x, y) and 3D ([1]), normal / |normal|
                              over the dimension's components, as the general path forms it */
} sm_collider;

/* Copies the definition, sets pose0 = pose1 = def->pose (or motion(user, 0) if a motion function
 * is set), velocities from the def. */
void sm_collider_init(sm_collider *c, const sm_collider_def *def);

/* The references a collider of the world holds on its mesh fields: taken when it is added
 * (sm_world_add_collider), dropped when the world is destroyed. */
void sm_collider_retain_meshes(sm_collider *c);
void sm_collider_release_meshes(sm_collider *c);

/* Prepares the step [t0, t0+dt]: pose1 from def->motion(t0+dt) if set, else by integrating the
 * constant linear/angular velocity exactly (rotation by the quaternion exponential); v and w are
 * the rigid velocity that carries pose0 to pose1 in dt (for a motion function: finite difference). */
void sm_collider_begin_step(sm_collider *c, double t0, double dt);

/* pose0 <- pose1, t0 <- t0 + dt (call after the step is accepted). */
void sm_collider_end_step(sm_collider *c);

/* Signed distance at x for pose `which` (0 = t^n, 1 = t^{n+1}; animated meshes at that time);
 * unit gradient in grad if not NULL.
 * In 2D (dim == 2) only x, y are used and grad[2] = 0. */
double sm_collider_phi(const sm_collider *c, int dim, int which, const double x[3], double grad[3]);

/* A lower bound of the signed distance over the axis-aligned box ctr +- half (pose `which`):
 * exact (to rounding) for a collider of one half-space, whose phi is linear, phi(ctr) - sum
 * |grad_a| half_a; otherwise the Lipschitz bound phi(ctr) - lip |half|. For culling: where it
 * is > 0, no point of the box is inside. */
double sm_collider_phi_box(const sm_collider *c, int dim, int which, const double ctr[3], const double half[3]);

/* Velocity of the collider's material at world point x (rigid: v + w x (x - origin1)), plus, for
 * a collider with an animated mesh nearest x, that mesh's surface velocity at t^{n+1}. */
void sm_collider_velocity(const sm_collider *c, int dim, const double x[3], double vel[3]);

#define SM_MAX_NODE_CONTACTS 4

/* What GRID_COLLISIONS recorded for one node: needed by FRICTION and by the implicit solver
 * (PRUNE_COLLISIONS). */
typedef struct sm_node_contact {
    int sticky;                               /* collider index that stuck this node, or -1 */
    int count;                                /* recorded slip/separate collisions */
    int body[SM_MAX_NODE_CONTACTS];           /* collider index of each */
    int stick[SM_MAX_NODE_CONTACTS];          /* 1: arriving at a sticky collider (infinite friction) */
    double n[SM_MAX_NODE_CONTACTS][3];        /* normal (grad phi at x-hat) of each */
} sm_node_contact;

/* GRID_COLLISIONS for one node at position xi (3 comps) with velocity v (in: v*, out: v-bar),
 * over all nc colliders in order, as Algorithm 7. rec receives the contacts (always written).
 * One deliberate extension: a node outside a sticky collider at t^n that would be inside at
 * t^{n+1} (phi_1(x-hat) < 0) is projected onto the surface and recorded as a contact with
 * stick = 1, which FRICTION treats as infinite friction (stopped relative to the collider), so a
 * no-slip ground is not penetrated by nodes arriving from above. Algorithm 7 only sticks nodes
 * already inside, which let a collapsing column sink about 0.7 dx into a sticky ground. */
void sm_collide_node(const sm_collider *cs, int nc, int dim, const double xi[3], double dt,
                     double v[3], sm_node_contact *rec);

/* The contact gate of a node (grid_collide.h, def.contact_gap): bit sm_gate_bit(b) set when material
 * lies within the gap of collider b. Colliders from index 7 on share the last bit. A separating
 * collider acts on a node only through an open bit; sticky and slip colliders always act. */
#define SM_GATE_OPEN 0xffu
static inline unsigned sm_gate_bit(int b) { return 1u << (b < 7 ? b : 7); }

/* The same over the colliders which[0 .. count-1] only (ascending indices into cs; the contacts name
 * the index into cs; which NULL: 0 .. count-1), with the node's contact gate (SM_GATE_OPEN: every
 * collider). Returns 1, the result then void, if a collider left v faster than sqrt(vcap2): the
 * caller's bound, which showed that the colliders left out cannot act on a node moving at most
 * that fast in this step (grid_collide_dim.c), no longer covers it. When it returns 0 the result
 * is that of all colliders (with the same gate). */
int sm_collide_node_among(const sm_collider *cs, const int *which, int count, int dim, const double xi[3], double dt,
                          double vcap2, unsigned gate, double v[3], sm_node_contact *rec);

/* FRICTION for one node: v (in: v-bar, out: v-tilde); dv = v-bar - v* is the collision impulse per
 * unit mass. For each recorded slip/separate collision b with normal n, relative velocity
 * vr = v - v_b, tangential part vt = vr - n (n . vr): v -= min(|vt|, mu_b |dv|) vt/|vt|.
 * Sticky nodes are unchanged. */
void sm_friction_node(const sm_collider *cs, int dim, const double xi[3], const sm_node_contact *rec,
                     const double dv[3], double v[3]);

/* Rotation matrix (row-major) of a unit quaternion (w,x,y,z). */
void sm_quat_to_mat(const double q[4], double R[9]);

#endif
