// Exact ordered tree edit distance (Zhang & Shasha 1989) with the Revolve paper's unit costs.
//
// A tree is given in pre-order as three arrays of equal length: a type id, the slot on the parent
// the node hangs from, and the parent's pre-order index (-1 for the root). Children are ordered
// as they appear in pre-order. Costs: removing or inserting a node 1; relabelling a node costs 1
// if its type differs plus 1 if its parent slot differs.
#pragma once

#include <cstdint>
#include <vector>

namespace treedit {

struct Tree {
    // Post-order view of the tree.
    std::vector<int32_t> type;
    std::vector<int32_t> slot;
    std::vector<int32_t> lmld;      // leftmost leaf descendant (post-order index)
    std::vector<int32_t> keyroots;  // increasing post-order indices
};

// Builds the post-order view; throws std::invalid_argument on a malformed tree.
Tree make_tree(const int32_t* types, const int32_t* slots, const int32_t* parents, int64_t n);

// The tree edit distance between two trees.
int32_t distance(const Tree& a, const Tree& b);

}  // namespace treedit
