// Everything that decides what a frame looks like, shared by rtpm-render, the master and clients.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace rtpm {

/// Eye-pass settings (docs/ARCHITECTURE.md §2 step 4).
struct EyeSettings {
    int maxDepth = 16;          ///< specular bounces before a path is ended
    int areaLightSamples = 4;   ///< shadow rays per emissive triangle (stratified) for a light
                                ///< of large solid angle; fewer for small or far ones (eye_light.cpp)
    int glossySamples = 4;      ///< BSDF samples per glossy vertex of an eye path (eye_glossy.cpp); a
                                ///< progressive pass draws one fresh sample there per pass
    bool operator==(const EyeSettings&) const = default;
};

/// Spatial index of a photon map (paper §5.2/§5.3, Table 5). Every variant answers the same
/// kNN queries (same photons, same result sets up to ties at the k-th distance) through
/// density.h's causticRadiance; they differ only in build cost, query speed and memory.
enum class PhotonTree : uint8_t {
    /// Unbalanced middle-split kd-tree with incremental batch insertion (kd_tree.h): the default.
    MiddleSplit = 0,
    /// Balanced median-split kd-tree (median_kd_tree.h), rebuilt from all photons every batch
    /// (it has no insertion): O(n log n) per batch.
    MedianBalanced = 1,
    /// Uniform grid (photon_grid.h), rebuilt from all photons every batch, O(n + cells); the
    /// resolution follows gridResolution().
    UniformGrid = 2,
};

/// How caustic radiance is estimated (docs/ARCHITECTURE.md §6).
enum class CausticEstimatorKind : uint8_t {
    /// Stochastic progressive photon mapping per pixel (Hachisuka & Jensen 2009) while camera and
    /// scene stay still: every frame gathers a new photon batch within each pixel's shrinking
    /// radius, and the image-space filter fades out (common/render/progressive.h). A frame after
    /// a camera move or an edit answers from the accumulated map, as knn does. The default.
    Progressive = 0,
    /// The paper's estimate: k nearest photons of the accumulated map, then the F×F box filter
    /// (fixed blur, no convergence). For reproducing the paper.
    Knn = 1,
};
/// "progressive", "knn" → kind; nullopt otherwise.
std::optional<CausticEstimatorKind> parseCausticEstimator(std::string_view name);
/// Inverse of parseCausticEstimator.
const char* causticEstimatorName(CausticEstimatorKind kind);

/// "middle", "median", "grid" (as the --tree flags take them) → variant; nullopt otherwise.
std::optional<PhotonTree> parsePhotonTree(std::string_view name);
/// Inverse of parsePhotonTree.
const char* photonTreeName(PhotonTree tree);

/// Upper bound of a progressive pass's batches (render/pass_budget.h; a pass of 1 024 batches of
/// the default 20 000 paths traces 20 M paths per set; the wire's FrameBegin.passBatches has the
/// same limit).
inline constexpr uint32_t kMaxPassBatches = 1024;
/// Largest number of Converging frames between two passes of a set that shoot (PassBudget::period).
inline constexpr uint32_t kMaxPassPeriod = 64;
/// The frame time a still view is held to unless --frame-budget-ms says otherwise: one refresh of
/// a 60 Hz display. A still frame then costs no more than a moving one on any built-in scene
/// (the cheapest moving frames, HEADLIGHT's walkthrough at 55–59 fps, take 17–18 ms), and the
/// photons per second stay as they were at 50 ms: a set off its turn costs almost nothing
/// (tests/bench/RESULTS.md, "Frame rate by mode").
inline constexpr double kDefaultFrameBudgetMs = 16.7;

/// Upper bound of PhotonSettings::progressiveGamma (wire and flag limit alike).
inline constexpr float kMaxProgressiveGamma = 16.0f;

/// Photon shooting and density-estimation settings (docs/ARCHITECTURE.md §5, paper §5.1/§5.4).
struct PhotonSettings {
    /// P: light paths traced per interleaving set per batch (pilots + refinements with SPT).
    uint32_t photonsPerBatch = 20000;
    /// Selective Photon Tracing (docs/ARCHITECTURE.md §5.2) instead of plain QMC shooting.
    bool selective = true;
    /// Diffuse bounces a photon may take before or between specular chains (0 → only L S+ D).
    uint32_t diffuseBounces = 1;
    /// Maximum ray segments per photon path.
    uint32_t maxDepth = 16;
    /// Photons per density estimate.
    uint32_t k = 64;
    /// Maximum gather radius in metres; 0 → 2 % of the scene's bounding-box diagonal, a size at
    /// which a k-photon estimate in a caustic is local but empty regions stop the search early.
    float rMax = 0.0f;
    /// Stored caustic photons per set at which that set stops shooting (walkthrough). A set also
    /// stops once it has traced kCapPathsPerPhoton × capPhotons paths, so scenes without caustic
    /// paths reach walkthrough too. 0 → no cap.
    uint64_t capPhotons = 2'000'000;
    /// Seed of every Halton rotation and hashed random number (same seed → same photons).
    uint64_t seed = 0x72'74'70'6d;
    /// SPT: target number of cells N_g per light and batch; 0 → a quarter of that light's share
    /// of photonsPerBatch. The real N_g is the largest product Π b_d^{k_d} not above the target.
    uint32_t sptCells = 0;
    /// SPT: refinements R per box of the refine set; 0 → chosen per batch so that
    /// pilots + R · (boxes refined) ≈ the light's share, capped at kMaxSptRefinements.
    uint32_t sptRefinements = 0;
    /// SPT: the refine set also holds the face neighbours (in Halton box space) of boxes that
    /// were productive in the previous batch, so a caustic's extent is found in a few batches.
    /// Correctness does not depend on it (photon_map.cpp: the estimate is unbiased for any
    /// refine set chosen before the batch); it trades yield for faster discovery.
    bool sptDilate = true;
    /// Spatial index of every set's map (PhotonTree). Needs a reset to change.
    PhotonTree tree = PhotonTree::MiddleSplit;
    /// Count only gathered photons visible from the query point (one shadow ray per photon of
    /// the k found): no caustic light leaks through thin walls within the gather radius
    /// (density.h), at the cost of k rays per estimate. Exact for planar receivers; on curved
    /// ones a chord below the surface can hide a photon. Off by default (the paper's estimate).
    bool gatherVisibility = false;
    /// Caustic estimator (CausticEstimatorKind): progressive by default, knn for the paper.
    CausticEstimatorKind estimator = CausticEstimatorKind::Progressive;
    /// Progressive: half-width Γ of the confidence intervals (in standard deviations) by which
    /// each pixel chooses its gather disc (common/render/progressive.h); in (0, 16]. Larger takes
    /// wider discs (less noise, more blur). On the curved-mirror reference with the photon cap
    /// (progressive.h maxDiscPhotons): defaults, 64 frames, Γ = 1 gave 0.0267 rel. MAE, 1.5
    /// 0.0285; M = 1, 12.8 M paths, Γ = 0.75 0.019, 1 0.020, 1.5 0.025. 1.5 stays the default
    /// because the estimator's own error figure tracks the true error within 1.5× with it and
    /// not with Γ = 1 (2.2× too high after 64 frames) (tests/bench/RESULTS.md).
    float progressiveGamma = 1.5f;
    bool operator==(const PhotonSettings&) const = default;
};

/// Image, interleaving, filter, eye-pass and photon settings of one rendering job.
struct RenderSettings {
    int width = 640;
    int height = 480;
    int interleave = 3;  ///< M: M×M interleaving sets (docs/ARCHITECTURE.md §3)
    int filter = 0;      ///< F: caustic box filter size; 0 → F = M (every window holds each set once)
    /// Display exposure in stops above the automatic one (1 / 99th-percentile luminance): the PNG's
    /// and the viewer's tone map only; the EXR and every radiance value are unaffected.
    float exposure = 0.0f;
    /// Progressive: the box filter leaves out of a pixel's window the neighbours whose caustic is
    /// more than this factor brighter or darker than the pixel's beyond their noise (a fold line
    /// or a caustic's rim; faded from 5 % of the window's mean on), so a window averages its own
    /// side of an edge instead of blurring both (box_filter.h edgeStoppingBox); 0 = every
    /// neighbour, the paper's box, which knn always shows.
    float filterEdges = 2.0f;
    EyeSettings eye;
    PhotonSettings photons;

    int filterSize() const { return filter > 0 ? filter : interleave; }
    /// The edge ratio the image is filtered with: filterEdges for the progressive estimator, 0
    /// (the plain box) for knn, the paper's estimator.
    float filterEdgeRatio() const {
        return photons.estimator == CausticEstimatorKind::Progressive ? filterEdges : 0.0f;
    }
    bool operator==(const RenderSettings&) const = default;
};

/// Throws std::invalid_argument naming the setting when a value is outside its row's limits
/// (common/core/knobs.h: zero or negative sizes, F over 64, k = 0, a non-finite or negative
/// radius, …) or M is larger than the image.
void validateSettings(const RenderSettings& settings);

/// The settings that decide an image, as the flags that give them ("--width 640 --height 480 -M 3
/// -F 3 -P 20000 --k 64 ... --exposure 0 --depth 16 ...": the rows of common/core/knobs.h in table
/// order, the two image-size rows first, then the live knobs, then the other fixed settings, a
/// switch only when it is given), for image metadata and logs. One line, stable order.
std::string describeSettings(const RenderSettings& settings);

}  // namespace rtpm
