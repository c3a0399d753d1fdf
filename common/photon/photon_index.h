// One interleaving set's photon index: the variant `--tree` selects, behind one insert/query API.
#pragma once

#include <cstdint>
#include <span>
#include <variant>
#include <vector>

#include "common/core/render_settings.h"
#include "common/photon/kd_tree.h"
#include "common/photon/median_kd_tree.h"
#include "common/photon/photon_grid.h"

namespace rtpm {

/// Uniform-grid resolution (cells along the photons' largest extent) for `photons` photons whose
/// bounding box has sides `extent` (m), k photons per estimate and gather radius rMax (m):
///  * cells no larger than rMax, so a query's initial search sphere overlaps at most 3 cells
///    per axis (resolution ≥ extent / rMax);
///  * and no larger than where a cell would hold about k photons if they covered one face of the
///    bounds evenly (resolution ≥ √(photons / k)): caustic photons lie on surfaces, so a
///    per-area count is the right measure, and k photons per cell keeps the scan near k;
///  * at most PhotonGrid::kMaxResolution, and reduced until the cell table (4 B per cell) holds
///    at most max(2 · photons, 4096) cells, so the table never costs more than 40 % of the
///    photons' own memory (20 B each).
/// Returns 1 … kMaxResolution. Pure function, O(kMaxResolution).
uint32_t gridResolution(uint64_t photons, Vec3 extent, uint32_t k, float rMax);

/// The photon index of one set: exactly one of KdTree (middle split, incremental insertion),
/// MedianKdTree or PhotonGrid (both rebuilt from all photons per batch). Callers insert batches
/// and run queries through `visit`, never switching on the variant themselves.
/// Thread safety: const members may run concurrently; insert needs exclusive access.
class PhotonIndex {
public:
    /// An empty index of kind `kind`; `rootBox` (scene bounds, m) is the middle-split tree's
    /// fixed root cell (the other variants take their photons' bounds at each rebuild).
    PhotonIndex(PhotonTree kind, Bounds rootBox);

    /// Adds a batch (powers already in the owner's unit). Middle split: incremental insertion,
    /// O(b·depth + size). Median tree and grid: rebuild from all photons, O(n log n) / O(n +
    /// cells); the grid's resolution follows gridResolution(n, extent, k, rMax).
    void insert(std::span<const Photon> batch, uint32_t k, float rMax);

    size_t size() const;
    /// Copy of every stored photon, in the index's order. O(n); for tests and tools.
    std::vector<Photon> photons() const;

    /// The concrete index if it is an `Index`, else null.
    template <class Index>
    const Index* get() const {
        return std::get_if<Index>(&index_);
    }
    /// Calls f(const KdTree&), f(const MedianKdTree&) or f(const PhotonGrid&) (a generic lambda
    /// runs the templated queries of density.h / knn.h on whichever variant is held).
    template <class F>
    decltype(auto) visit(F&& f) const {
        return std::visit(std::forward<F>(f), index_);
    }

private:
    std::variant<KdTree, MedianKdTree, PhotonGrid> index_;
};

}  // namespace rtpm
