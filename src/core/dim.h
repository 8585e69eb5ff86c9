/* The dimension of a dimension-generic source (the *_dim.c files, DESIGN §2).
 *
 * CMake compiles every file of SM_DIM_SOURCES twice, with -DSM_DIM=2 and -DSM_DIM=3. Such a
 * file includes this header first; it writes its loops over D (and DD = D * D) values, which are
 * then compile-time constants, and names every external function SM_FN(name): name_2d or
 * name_3d. The world picks the 2D or the 3D table of stages once, at creation
 * (integrate/stages.h). Headers that declare SM_FN functions are included only by such files. */
#ifndef SM_CORE_DIM_H
#define SM_CORE_DIM_H

#ifndef SM_DIM
#error "SM_DIM must be 2 or 3 (dimension-generic sources are compiled once per dimension)"
#endif

#define D SM_DIM
#define DD (D * D)
#if D == 2
#define SM_FN(name) name##_2d
#elif D == 3
#define SM_FN(name) name##_3d
#else
#error "SM_DIM must be 2 or 3"
#endif

#define BN (D == 2 ? 16 : 64) /* nodes per grid block (4^d) */
#define NGB (1 << D)          /* grid blocks a particle block touches (2^d) */
#define NCOLORS (1 << D)      /* block colours: block coordinates mod 2 */

#endif
