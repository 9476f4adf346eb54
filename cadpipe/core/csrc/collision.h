/* What the collision kernels share: the stage codes of cadpipe.collision.reports.STAGES and
 * the 18-DOP's directions (cadpipe.collision.bounds). The Python modules check theirs
 * against collision_constants() when imported. */
#ifndef CP_COLLISION_H
#define CP_COLLISION_H

/* the stages that decide a pair (indices into reports.STAGES) */
enum {
    ALLOWED = 0, AABB = 1, KDOP = 2, OBB = 3, HULL = 4, FCL = 6, CONTAINMENT = 7, ANALYTIC = 8,
    NOT_CHECKED = 9,
    UNSETTLED = -1,    /* left to the Python narrow phase (also the funnel's NARROW) */
    REFUSED = -2,      /* collide_pose: a pose as_pose refuses; nothing decided */
};
#define NARROW UNSETTLED
/* GJK steps of the funnel's hull stage (cadpipe.collision.convex.FUNNEL_ITERATIONS) */
#define FUNNEL_ITERATIONS 10
/* 1 / sqrt(2) as numpy rounds it (bounds.KDOP_DIRECTIONS) */
#define KDOP_D 0x1.6a09e667f3bccp-1

/* the 9 directions of an 18-DOP: the axes and the 6 face diagonals, unit length */
static const double KDOP_DIRECTIONS[9][3] = {
    {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {KDOP_D, KDOP_D, 0}, {KDOP_D, -KDOP_D, 0},
    {KDOP_D, 0, KDOP_D}, {KDOP_D, 0, -KDOP_D}, {0, KDOP_D, KDOP_D}, {0, KDOP_D, -KDOP_D}};

#endif
