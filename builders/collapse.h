#pragma once
// Collapse of a tree into a wider one: a pass from any common-format Bvh to arity 4 or 8 (DESIGN.md,
// "passes: collapse to 4/8-wide"). The leaves keep their references; the output is laid out depth first
// with every node's children contiguous, and its prim_refs are the input's, leaf by leaf in output order.

#include <cstdint>

#include "core/bvh.h"
#include "core/sah.h"

namespace sahbench {

/// Greedy collapse: each output node starts with the children of an input node, then repeatedly
/// replaces the inner child of largest surface area by that child's own children, while the result
/// still has at most `arity` children (Wald, Benthin and Boulos 2008, "Getting Rid of Packets"; the rule
/// Embree's BVHN builders apply while building). Works on any input arity up to `arity`; input leaves
/// stay leaves, so every primitive keeps its leaf.
Bvh collapse_greedy(const Bvh& bvh, uint32_t arity);

/// SAH-optimal collapse of a binary tree (Ylitie, Karras and Laine 2017, "Efficient Incoherent Ray
/// Traversal on GPUs Through Compressed Wide BVHs", section 4.1): dynamic programming over the binary
/// nodes finds, for each subtree and each i <= arity, the cheapest way to represent it as at most i
/// subtrees, each an inner wide node or a leaf. A leaf may merge a whole input subtree of at most
/// `max_leaf` references. Costs use `cost` (c_trav per wide node visited, c_isect per reference), the
/// model of core/sah.h and of the statistics, so the result is optimal for the SAH the CSV reports among
/// wide trees whose nodes are unions of the input's. Throws Error for a non-binary input.
Bvh collapse_sah(const Bvh& bvh, uint32_t arity, const SahCost& cost, uint32_t max_leaf);

}  // namespace sahbench
