/* The one tree layout: a perfect binary tree in heap order.
 *
 * Node 0 is the root and node k's children are 2k + 1 and 2k + 2; the 2**depth leaves
 * are the last nodes (leaf L is node 2**depth - 1 + L) and hold items in a given order,
 * leaf L the items [L * leaf_size, (L + 1) * leaf_size) of it. So a walk needs no child
 * or range tables: a node's leaves, and the items under it, follow from its index.
 */
#ifndef CP_TREE_H
#define CP_TREE_H

#include <stdint.h>

/* The depth of the tree over ``count`` leaves (0 for one). */
static inline int tree_depth(int64_t count)
{
    int depth = 0;
    while (((int64_t)1 << depth) < count)
        depth++;
    return depth;
}

/* The level of ``node`` (the root's is 0). */
static inline int tree_level(int64_t node)
{
    int level = 0;
    while (((int64_t)2 << level) - 1 <= node)
        level++;
    return level;
}

/* The leaves under ``node`` of a tree of ``depth``: [first, first + count). */
static inline void tree_leaves(int64_t node, int depth, int64_t *first, int64_t *count)
{
    int level = tree_level(node);
    int64_t width = (int64_t)1 << (depth - level);
    *first = (node - (((int64_t)1 << level) - 1)) * width;
    *count = width;
}

#endif
