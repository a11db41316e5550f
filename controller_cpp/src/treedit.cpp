// Zhang-Shasha tree edit distance and its Python bindings (module evolution._treedit).
#include "treedit.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

namespace nb = nanobind;

namespace treedit {

Tree make_tree(const int32_t* types, const int32_t* slots, const int32_t* parents, int64_t n) {
    Tree t;
    if (n == 0) return t;
    if (parents[0] != -1) throw std::invalid_argument("the first node (pre-order root) must have parent -1");
    std::vector<std::vector<int32_t>> children(n);
    for (int64_t k = 1; k < n; ++k) {
        const int32_t p = parents[k];
        if (p < 0 || p >= k)
            throw std::invalid_argument("node " + std::to_string(k) + " has parent " + std::to_string(p) +
                                        "; in pre-order a parent comes before its children");
        children[p].push_back(static_cast<int32_t>(k));
    }
    // Pre-order with children in order means each child's subtree follows its parent
    // contiguously; check it so that the post-order below is the tree that was meant.
    std::vector<int64_t> end(n);  // one past the last pre-order index of each subtree
    for (int64_t k = n - 1; k >= 0; --k) {
        int64_t e = k + 1;
        for (int32_t c : children[k]) {
            if (c != e) throw std::invalid_argument("parents do not describe a pre-order numbering");
            e = end[c];
        }
        end[k] = e;
    }
    if (end[0] != n) throw std::invalid_argument("parents do not describe a single tree");

    t.type.resize(n);
    t.slot.resize(n);
    t.lmld.resize(n);
    std::vector<int32_t> post(n);  // pre-order index -> post-order index
    // Iterative post-order traversal.
    std::vector<std::pair<int32_t, size_t>> stack{{0, 0}};
    int32_t next = 0;
    while (!stack.empty()) {
        auto& [node, child] = stack.back();
        if (child < children[node].size()) {
            const int32_t c = children[node][child++];
            stack.push_back({c, 0});
        } else {
            post[node] = next;
            t.type[next] = types[node];
            t.slot[next] = slots[node];
            t.lmld[next] = children[node].empty() ? next : t.lmld[post[children[node][0]]];
            ++next;
            stack.pop_back();
        }
    }
    // Keyroots: the highest post-order node for each distinct leftmost leaf.
    std::vector<int32_t> last(n, -1);
    for (int32_t i = 0; i < n; ++i) last[t.lmld[i]] = i;
    for (int32_t i = 0; i < n; ++i)
        if (last[i] >= 0) t.keyroots.push_back(last[i]);
    std::sort(t.keyroots.begin(), t.keyroots.end());
    return t;
}

int32_t distance(const Tree& a, const Tree& b) {
    const int32_t na = static_cast<int32_t>(a.type.size());
    const int32_t nb_ = static_cast<int32_t>(b.type.size());
    if (na == 0) return nb_;
    if (nb_ == 0) return na;
    std::vector<int32_t> td(static_cast<size_t>(na) * nb_, 0);
    std::vector<int32_t> fd(static_cast<size_t>(na + 1) * (nb_ + 1), 0);
    const int32_t w = nb_ + 1;
    for (int32_t i : a.keyroots) {
        for (int32_t j : b.keyroots) {
            const int32_t li = a.lmld[i], lj = b.lmld[j];
            const int32_t m = i - li + 2, n = j - lj + 2;
            fd[0] = 0;
            for (int32_t x = 1; x < m; ++x) fd[x * w] = fd[(x - 1) * w] + 1;
            for (int32_t y = 1; y < n; ++y) fd[y] = fd[y - 1] + 1;
            for (int32_t x = 1; x < m; ++x) {
                const int32_t ax = x + li - 1;
                for (int32_t y = 1; y < n; ++y) {
                    const int32_t by = y + lj - 1;
                    const int32_t del = fd[(x - 1) * w + y] + 1;
                    const int32_t ins = fd[x * w + y - 1] + 1;
                    int32_t best;
                    if (a.lmld[ax] == li && b.lmld[by] == lj) {
                        const int32_t ren = (a.type[ax] != b.type[by]) + (a.slot[ax] != b.slot[by]);
                        best = std::min({del, ins, fd[(x - 1) * w + y - 1] + ren});
                        td[static_cast<size_t>(ax) * nb_ + by] = best;
                    } else {
                        const int32_t p = a.lmld[ax] - li, q = b.lmld[by] - lj;
                        best = std::min({del, ins, fd[p * w + q] + td[static_cast<size_t>(ax) * nb_ + by]});
                    }
                    fd[x * w + y] = best;
                }
            }
        }
    }
    return td[static_cast<size_t>(na - 1) * nb_ + (nb_ - 1)];
}

}  // namespace treedit

namespace {

using IntArray = nb::ndarray<const int32_t, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

treedit::Tree tree_from(const IntArray& types, const IntArray& slots, const IntArray& parents) {
    if (types.shape(0) != slots.shape(0) || types.shape(0) != parents.shape(0))
        throw std::invalid_argument("types, slots and parents must have the same length");
    return treedit::make_tree(types.data(), slots.data(), parents.data(),
                              static_cast<int64_t>(types.shape(0)));
}

int32_t py_distance(const IntArray& ta, const IntArray& sa, const IntArray& pa,
                    const IntArray& tb, const IntArray& sb, const IntArray& pb) {
    const treedit::Tree a = tree_from(ta, sa, pa);
    const treedit::Tree b = tree_from(tb, sb, pb);
    nb::gil_scoped_release release;
    return treedit::distance(a, b);
}

nb::ndarray<nb::numpy, int32_t, nb::ndim<2>> py_pairwise(const IntArray& types, const IntArray& slots,
                                                          const IntArray& parents,
                                                          const IntArray& offsets) {
    if (types.shape(0) != slots.shape(0) || types.shape(0) != parents.shape(0))
        throw std::invalid_argument("types, slots and parents must have the same length");
    const size_t n_off = offsets.shape(0);
    if (n_off == 0) throw std::invalid_argument("offsets must hold at least one value (0)");
    const int32_t* off = offsets.data();
    if (off[0] != 0 || off[n_off - 1] != static_cast<int32_t>(types.shape(0)))
        throw std::invalid_argument("offsets must start at 0 and end at the total node count");
    const size_t count = n_off - 1;
    // All offsets checked before any tree is read: with a later offset past the end (say
    // [0, 100, 5] over 5 nodes) the first tree would otherwise be read out of bounds.
    for (size_t k = 0; k < count; ++k) {
        if (off[k + 1] < off[k]) throw std::invalid_argument("offsets must not decrease");
    }
    std::vector<treedit::Tree> trees;
    trees.reserve(count);
    for (size_t k = 0; k < count; ++k) {
        trees.push_back(treedit::make_tree(types.data() + off[k], slots.data() + off[k],
                                           parents.data() + off[k], off[k + 1] - off[k]));
    }
    auto* out = new int32_t[count * count == 0 ? 1 : count * count]();
    {
        nb::gil_scoped_release release;
        for (size_t i = 0; i < count; ++i)
            for (size_t j = i + 1; j < count; ++j) {
                const int32_t d = treedit::distance(trees[i], trees[j]);
                out[i * count + j] = d;
                out[j * count + i] = d;
            }
    }
    nb::capsule owner(out, [](void* p) noexcept { delete[] static_cast<int32_t*>(p); });
    return nb::ndarray<nb::numpy, int32_t, nb::ndim<2>>(out, {count, count}, owner);
}

}  // namespace

NB_MODULE(_treedit, m) {
    m.doc() = "Exact Zhang-Shasha tree edit distance with the Revolve paper's unit costs.";
    m.def("distance", &py_distance, nb::arg("types_a"), nb::arg("slots_a"), nb::arg("parents_a"),
          nb::arg("types_b"), nb::arg("slots_b"), nb::arg("parents_b"),
          "Tree edit distance between two pre-order trees (int32 arrays: type id, parent slot, "
          "parent index with -1 for the root).");
    m.def("pairwise", &py_pairwise, nb::arg("types"), nb::arg("slots"), nb::arg("parents"),
          nb::arg("offsets"),
          "Symmetric matrix of distances between trees concatenated in the arrays; tree k spans "
          "offsets[k]:offsets[k+1].");
}
