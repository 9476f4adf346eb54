/* The one tree layout: a perfect binary tree in heap order.
 *
 * Node 0 is the root and node k's children are 2k + 1 and 2k + 2; the ``leaves`` =
 * 2**depth leaves are the last nodes (leaf L is node leaves - 1 + L), 2 leaves - 1 nodes
 * in all. Leaf L holds the items [L * leaf_size, (L + 1) * leaf_size) of the tree's order
 * (cadpipe.core.tree.BoxTree: Morton, median-split or sequence order). A walk carrying
 * each node's ``span`` (the leaves under it: the root's is ``leaves``, a child's half
 * its parent's) finds the node's items without any table. Every tree of cadpipe is laid
 * out so: box trees over triangles, segments and boxes, the capsule trees of chains.
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

/* The leaves of a tree of ``nodes`` nodes. */
static inline int64_t tree_leaf_count(int64_t nodes) { return (nodes + 1) / 2; }

/* The first item under ``node`` at ``span`` of a tree of ``leaves`` leaves. */
static inline int64_t tree_first_item(int64_t node, int64_t span, int64_t leaves,
                                      int64_t leaf_size)
{
    return ((node + 1) * span - leaves) * leaf_size;
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
