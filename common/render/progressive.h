// The consistent caustic estimator of a still view: every photon of every pass counted, the
// gather radius chosen per eye hit after the fact.
//
// Each diffuse end point of a pixel's eye path (EyeHit) keeps a ladder of kRadiusBins
// concentric discs (radii r_j = R₀ · kBinRatio^j; R₀² is kOuterArea × the restart map's k-NN
// disc) and, per ring between two discs, the power and count of every photon that fell into it
// — over the accumulated map at the restart and over every progressive pass since. With B
// batches in all, the disc j gives the kernel estimate
//   E_j = Σ_{r < r_j} Φ_p / (π r_j² B)      with standard deviation  σ_j ≈ E_j / √n_j
// (n_j the disc's photons weighed by their power, (Σw)²/Σw² for luminances w: the photon count
// where all carry one power, far fewer where one SPT pilot outside the refined boxes carries up
// to 1 + R times the others'), unbiased for the density smoothed over r_j.
// Which disc a pixel shows is chosen when the frame is composed, by the
// intersection-of-confidence-intervals rule (Goldenshluger & Nemirovski 1997, Katkovnik 1999):
// from the disc holding exactly kMinPhotons photons outwards, keep E_j ± Γσ_j (Γ wider while
// few photons are in: earlyGamma) as long as every
// interval met so far still overlaps, and no disc holding more than maxDiscPhotons (k·√(N/20 000)
// for N paths); the last such disc is shown. A larger disc is taken only while the estimate does
// not move beyond its noise, so a flat region gets a wide disc (little noise) and a fold line or
// cusp a narrow one (little blur). Where the photons around a hit lie strung along a line (a fold
// line, a rim) its discs become ellipses of the same areas, long along the line (Shape,
// kShapePhotons): the same photons with a fraction of the blur across it.
// The result does not depend on how photons were split into passes: the rings hold the same
// photons whether they came as 160 passes of 20 000 paths or 2 of 1.6 M, the ladder reaches
// beyond the first batch's k-NN disc, and the cap counts photons, not passes (within 6 % on the
// curved mirror, tests/accuracy/progressive_estimator_test.cpp). A pass of several batches
// (growing still-view passes) simply adds them. This replaces shrinking-radius SPPM, whose
// radius at a given photon count depended on the first pass's size.
// A pass gathers only the rings the rule may still choose (up to kActiveMargin rings outside the
// shown one, none outside the ring of a capped one), so its cost is O(log b + photons near the
// shown disc), not the map's size.
// Direct light from area lights converges as before: one more rotated sample set per pass.
// Every set's photons reach every pixel: a pass bins its own set's new photons and every other
// set's shot of kSharedPhotonLag frames ago (SharedPhotons; in a cluster the master forwards
// them, a few hundred kB a frame), so after a few passes a pixel's estimate holds M² × the
// photons its own set shot. Before that the box filter of the master averages the M² sets'
// estimates; Γ's noise term counts that averaging (setFilterShare), so the rule balances blur
// against the shown image's noise, not one set's. Where the sets take turns (pass_budget.h) a
// pass off its set's turn only shows the last pixels (skip); its next pass bins every shot
// shared since.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "common/core/pixel_radiance.h"
#include "common/photon/photon_map.h"
#include "common/photon/visible_from.h"
#include "common/scene/scene.h"
#include "common/trace/eye_pass.h"

namespace rtpm {

/// Rings of the radius ladder: the innermost disc has 1/256 of the outer radius, so the ladder
/// holds the radius a pixel needs over 65 536 × the restart's photon density.
inline constexpr int kRadiusBins = 20;
/// Squared-radius ratio between neighbouring discs (r² halves every 1.25 rings).
inline constexpr double kBinRatio2 = 0.5743491774985174;  // 2^(−0.8)
/// The rule starts from the disc holding exactly this many photons (within the first ring that
/// reaches them, its photons taken as spread evenly over its area; then whole rings outwards).
/// Starting at that ring's whole disc made the start jump from ring to ring as a pixel moved
/// away from a bright edge: concentric rings around GLASS's spot and in EGG's shadow, and 5-9 %
/// more light than arrives inside the curved and flat mirrors' fold caustics (now 2-7 %; the
/// curved mirror's rel. MAE 0.0568 / 0.0182 at frames 4 / 64 against 0.0539 / 0.0177 now,
/// tests/bench/ring_mirror_bench --photons 20000 --frames 64 --frame-budget-ms 0). Fewer make its
/// noise figure itself noisy: with 8, sparse regions (RING's floor under one diffuse bounce)
/// stopped at small discs by chance and showed speckles; on the curved mirror (defaults, 48
/// frames) 8 gave 0.0316 rel. MAE, 16 0.0311, 32 0.0346 (and a blurrier first frame: 0.108).
inline constexpr float kMinPhotons = 16.0f;
/// Rings kept active outside the shown disc (a pass gathers within the outermost active one):
/// r² 5.3 × the shown disc's. On the curved mirror (defaults, 64 frames, one batch per pass,
/// 320×240): 2 gave 0.0287 rel. MAE in 4.6 s, 3 0.0279 in 4.9 s, 4 0.0285 in 5.7 s; keeping every
/// ring was worse (0.038 at 48 frames): the rule alone takes discs somewhat too wide at fold lines.
/// Where the cap ended the walk (Choice::capped) only the ring holding the cap's edge stays active
/// outside it: the cap grows as √N, a disc's photons as N, so a capped disc only narrows as photons
/// accumulate (curved mirror, defaults, 64 frames at budget 0: the same image in 3.82 s instead
/// of 4.30 s).
inline constexpr int kActiveMargin = 3;
/// The ladder's outer disc has this many times the area of the restart map's k-NN disc, so a
/// restart from a large first batch (the map's k photons in a small disc) leaves the rule the
/// discs the same photons would offer after many small passes (maxDiscPhotons decides instead).
/// M = 1, plain shooting, 3.2 M paths as 20 000 × 160, 400 000 × 8 and 1.6 M × 2 passes, rel.
/// MAE: curved mirror, the k-NN disc 0.033, 0.033, 0.038 (Γ = 1), 4 × its area 0.033, 0.034,
/// 0.033; glass slab (tests/accuracy/glass_slab_test.cpp), 4 × 0.0105, 0.0100, 0.0118, 8 ×
/// 0.0105, 0.0098, 0.0108 (a smooth caustic takes the cap, 810 photons, which 4 × did not hold).
inline constexpr float kOuterArea = 8.0f;
/// The discs' shape (Shape): a hit's discs stay circles until the photons it binned (the
/// restart's within its active disc, then each pass's) number kShapePhotons; then, where the
/// covariance of their offsets in the surface has eigenvalues λ₁/λ₂ ≥ kAspectMin (photons strung
/// along a fold line or a rim, or a steep gradient), they become ellipses of the circles' area,
/// aspect a = min(kAspectMax, (λ₁/λ₂)^kAspectPower), long along λ₁'s axis, for the rest of the
/// progression. A fold line's error grows as the square root of the width a disc reaches across
/// it, so an ellipse of aspect a sheds 1 − a^(−1/4) of it (29 % at 4) with the same photons, the
/// same noise and, for a density that changes along the fold line only slowly, no more bias.
/// Every ring keeps a kernel estimate of area π r_j² (the photons binned before the decision in
/// circles, the rest in ellipses), so the estimate stays consistent. In the pass that decides,
/// its photons first add to the moments and then, if they decide an ellipse, are binned in it:
/// one pass of 31 batches and 31 passes of one give the same image within 2 % (growing passes).
/// Defaults, 320×240, one batch a pass (tests/bench/ring_mirror_bench --photons 20000
/// --frame-budget-ms 0), rel. MAE at frames 1 / 8 / 32 with circles → ellipses:
///   curved mirror 0.0925 / 0.0366 / 0.0198 → 0.0703 / 0.0242 / 0.0123 (in 2.0 → 2.95 s),
///   its variant (--light -0.3,0.7,0.35 --ring-height 0.5) 0.1095 / 0.0546 / 0.0356 → 0.1054 /
///   0.0453 / 0.0322 (2.49 → 3.02 s); the flat mirror (tests/accuracy) at frames 1 / 4 / 16 / 24
///   0.0983 / 0.0526 / 0.0320 / 0.0250 → 0.0712 / 0.0390 / 0.0140 / 0.0105; the glass scenes'
///   smooth caustics keep their circles (the same figures).
/// Tried: kShapePhotons 128 or 256 (decided after the restart: curved mirror 0.0923 / 0.0925 at
/// frame 1, then within 3 %; 256 with kAspectMin 2 drew the cleanest halo around GLASS's spot
/// with M = 1), kAspectMin 1.25 / 2 (0.0243 / 0.0255 at frame 8 against 0.0246), kAspectMax
/// 2.5 / 8 (0.0275 / 0.0223 at frame 8, 8 costing 30 % more time), powers 1 / 2 (0.0267 /
/// 0.0243).
inline constexpr double kShapePhotons = 64.0;
inline constexpr double kAspectMin = 1.5;
inline constexpr double kAspectMax = 4.0;
inline constexpr double kAspectPower = 1.5;
/// Paths per unit of maxDiscPhotons (the default P of one batch).
inline constexpr double kDiscCapPaths = 20000.0;
/// The widest disc the rule may show holds at most k·√(N / kDiscCapPaths) photons — exactly that
/// many where the cap ends the walk, the disc then lying within a ring (Choice::scale) — N the paths
/// traced since the restart (every batch of the map and the passes): k at the first default
/// batch, growing more slowly than N so the shown disc still shrinks (consistency), and the
/// same for the same photons however they were batched. Without it the rule alone took discs
/// too wide (a wide disc's small bias hides in its small noise at fold lines): curved mirror,
/// M = 1, plain shooting, 12.8 M paths as 20 000 × 640 and 1.6 M × 8 passes, rel. MAE 0.0275
/// against 0.0205 without the cap (Γ = 1), 0.0203 against 0.0205 with it. A cap at whole rings
/// only (the last disc below it, 0.57–1 × the cap) showed a smooth caustic with more noise than
/// knn's k photons: the glass slab at the defaults read 0.0201 / 0.0069 at frames 1 / 24 against
/// 0.0170 / 0.0062 interpolated (curved mirror 0.0861 / 0.0176 at frames 1 / 64 against 0.0888 /
/// 0.0179, flat mirror 0.0877 / 0.0292 against 0.0899 / 0.0294 at frames 1 / 24).
inline double maxDiscPhotons(uint32_t k, double paths) {
    return double(k) * std::sqrt(std::max(1.0, paths / kDiscCapPaths));
}
/// The box filter's share (frame_image.h) of a pixel whose shown disc has radius r, with h the
/// half-width of the filter's window on the surface (F/2 pixel footprints): the pixel's own
/// estimate alone (weight 1) while r ≤ kOwnFull·h, the filter alone from r ≥ kOwnNone·h, linear
/// between; where the cap ended the rule's walk (Choice::capped: no change in density stopped
/// it, a smooth caustic) kOwnFullCapped and kOwnNoneCapped instead. A disc much wider than the
/// window blurs more than the window does, so the filter's average over all M² sets (every set's
/// photons, M² × less noise) costs nothing; a disc within the window sees detail the window would
/// blur, so the pixel shows its own set's estimate (from its own, noisier choice: Γ without the
/// filter's share), which holds every set's photons once the shared shots arrive (pass).
/// Until 2026-11-28 every pixel took (0.5, 1): where the rule stopped at a change in density (a
/// fold line, a rim) the window then averaged both sides of it whenever the disc was a little
/// wider than half the window, and its stop at edges (box_filter.h) allows twice the Poisson
/// noise, which over-states the noise of QMC photons (the count in a fixed disc varies across the
/// sets' rotations by 0.1–0.16 × its mean, not 1 ×). On a smooth caustic the filter's average of
/// the M² sets' choices still pays, so capped discs keep (0.5, 1).
/// Curved mirror variant (tests/bench/ring_mirror_bench --photons 20000 --frame-budget-ms 0
/// --light -0.3,0.7,0.35 --ring-height 0.5), frames 4 / 8 / 16, wall s and rel. MAE: every pixel
/// (0.5, 1) 0.34 0.0794 / 0.58 0.0639 / 1.05 0.0487; every pixel (0.75, 1.5) 0.37 0.0732 / 0.65
/// 0.0537 / 1.27 0.0422; capped (0.5, 1), others (0.75, 1.5) 0.0736 / 0.0546 at frames 4 / 8
/// (tests/accuracy, 320×240); others (0.75, 2) 0.39 0.0698 / 0.75 0.0519 / 1.46 0.0420 (more
/// pixels bin the shared photons, so frames cost more). Analytic scenes (tests/accuracy, 160×120,
/// frames 1 / 4 / 16 / 24), before → now: glass slab 0.0128 / 0.0145 / 0.0072 / 0.0064 → 0.0128 /
/// 0.0122 / 0.0070 / 0.0063 (every pixel (0.75, 1.5): 0.0128 / 0.0122 / 0.0073 / 0.0069), glass
/// ball 0.0228 / 0.0160 / 0.0101 → 0.0228 / 0.0152 / 0.0101 at frames 1 / 4 / 16 (every pixel
/// (0.75, 1.5): 0.0248 / 0.0161 / 0.0107), flat mirror 0.0983 / 0.0521 / 0.0329 / 0.0260 →
/// 0.0983 / 0.0526 / 0.0320 / 0.0250. Others (1, 2) read the error figure at up to 1.49 × the
/// true error on the curved mirror (shown_change.h), (0.75, 2) 1.45 ×, (0.75, 1.5) 1.39 ×.
inline constexpr double kOwnFull = 0.75, kOwnNone = 1.5;
inline constexpr double kOwnFullCapped = 0.5, kOwnNoneCapped = 1.0;

/// The confidence width the rule uses while few photons are in: Γ × (1 + kEarlyGamma × (1 − x /
/// kEarlyPaths)) with x = N / kDiscCapPaths − 1 for N paths (as maxDiscPhotons counts them), Γ
/// itself from N = (1 + kEarlyPaths) × kDiscCapPaths on: at the defaults Γ × 4/3, 11/9, 10/9 at
/// frames 1, 2, 3. Counted in paths, not passes, so it too does not care how photons are batched.
/// While the cap (maxDiscPhotons) is about the k-NN disc itself, the rule can only narrow the disc
/// knn shows, over two or three rings of few photons each, and one chance stop there shows a
/// disc of half the photons; a wider interval takes a narrower disc only where the density
/// clearly changes. Defaults, rel. MAE at frames 1 / 2 / 3 / 24 (64 for the curved mirror)
/// against knn:
///   glass slab 0.0125 / 0.0124 / 0.0125 / 0.0062 (Γ alone: 0.0170 / 0.0166 / 0.0146 / 0.0062;
///     knn 0.0133 / 0.0147 / 0.0144 / 0.0150),
///   flat mirror 0.0995 / 0.0738 / 0.0610 / 0.0294 (Γ alone 0.0899 / 0.0679 / 0.0583 / 0.0294;
///     knn 0.1107 / 0.0805 / 0.0690 / 0.0343),
///   curved mirror 0.0959 / 0.0736 / — / 0.0182 (Γ alone 0.0888 / 0.0706 / — / 0.0182; knn
///     0.1129 / 0.0852 / — / 0.0450).
/// Checked afterwards on a scene not used to choose it, the glass ball's focused spot
/// (tests/accuracy/glass_sphere_test.cpp): 0.0230 / 0.0201 / 0.0185 / 0.0100 at frames 1 / 2 / 3 /
/// 16 (Γ alone 0.0248 / 0.0219 / 0.0188 / 0.0100; knn 0.0350 / 0.0289 / 0.0279 / 0.0280).
/// Γ × 4/3 throughout lost to knn on the flat mirror at frame 24 (0.0351 against 0.0343); the
/// boost fading over 6 or 12 batches kept the slab further ahead but cost the mirrors at frames
/// 2–6.
inline constexpr double kEarlyGamma = 1.0 / 3.0;
inline constexpr double kEarlyPaths = 3.0;
inline double earlyGamma(double gamma, double paths) {
    const double x = paths / kDiscCapPaths - 1.0;
    return gamma * (1.0 + kEarlyGamma * std::clamp(1.0 - x / kEarlyPaths, 0.0, 1.0));
}

/// Per-frame figures of the caustic estimate of one set (for the error estimate).
struct CausticErrorSums {
    double sigma = 0.0;     ///< Σ over pixels of the estimate's standard deviation (luminance)
    double radiance = 0.0;  ///< Σ over the same pixels of the estimate (luminance)
    uint64_t pixels = 0;    ///< pixels with a caustic estimate
    /// The set's own batches in its estimate (ProgressiveSet::batches): how far the progression
    /// went, which the shown caustic's change since a share of it needs (shown_change.h).
    double batches = 0.0;
    CausticErrorSums& operator+=(const CausticErrorSums& o) {
        sigma += o.sigma;
        radiance += o.radiance;
        pixels += o.pixels;
        batches += o.batches;
        return *this;
    }
};

/// Relative error of the shown caustic the figures predict: per pixel σ is the noise of the
/// chosen disc and its blur (Choice::drift) in quadrature, and √(2/π) σ (the mean absolute
/// deviation of a normal variable) summed over the caustic region and divided by its radiance
/// is the caustic-region rel. MAE (common/image/error_metrics.h) that error would give.
/// On the four analytic scenes at the defaults it read 0.43–3.3 × the true error (Poisson's count
/// over-states the noise of QMC photons on smooth glass caustics; the box filter's blur is not
/// in it), so what rtpm-render and the master print is the shown caustic's change since a sixth
/// of the progression's photons (common/image/shown_change.h), and this figure only until that is known
/// (a progression's first frame or first turns). 0 when no pixel has a caustic.
inline double causticErrorEstimate(const CausticErrorSums& e) {
    return e.radiance > 0.0 ? 0.7978845608028654 * e.sigma / e.radiance : 0.0;
}

/// The progressive state of one set's pixels. Not thread-safe; each call uses every core (TBB)
/// and its result does not depend on the thread count.
class ProgressiveSet {
public:
    /// True after a restart, until invalidate().
    bool valid() const { return valid_; }
    /// Forgets the state (camera or scene changed); the next frame restarts.
    void invalidate() { valid_ = false; }
    /// Camera of the current progression (meaningful when valid()).
    const Camera& camera() const { return camera_; }
    /// Passes since the restart (0 right after it).
    uint32_t passes() const { return passes_; }
    /// Diffuse end points held (for tests and figures).
    size_t hitCount() const { return records_.hits.size(); }
    /// The set's own batches counted in the estimate (the map's at the restart plus every
    /// pass's); a hit adds the other sets' batches it binned.
    double batches() const { return batches_; }
    /// The error figures of the last composed frame.
    const CausticErrorSums& errorSums() const { return error_; }
    /// Share of a set's variance left in the shown image when the box filter averages F² sets
    /// whose photons are all their own (1/F², 1 without filter). Set before restart(). Photons
    /// shared between the sets (pass) are common to the averaged pixels, so the share the rule
    /// uses grows towards 1 with them: 1 − (1 − s)·own/all, own the batches only this set binned
    /// (its restart map and its own passes), all every batch binned.
    void setFilterShare(double share) { rule_.filterShare = share; }
    /// The image geometry the set's pixels take: interleave M, box filter F, the set's columns.
    void setImage(int m, int f, int columns) {
        image_ = Image{m, f, columns};
    }
    /// Per pixel of the set, the weight its own estimate gets against the box filter (frame_image.h).
    const std::vector<uint8_t>& ownWeights() const { return ownWeights_; }
    /// Per pixel of the set, the Poisson noise of its caustic value (the filtered choice's and its
    /// own, by the own weight) relative to that value, in 64ths (0..255: up to 4 ×): the master's
    /// filter takes a difference within it for noise, not an edge (box_filter.h edgeStoppingBox).
    const std::vector<uint8_t>& noise() const { return noise_; }

    /// Restart from a record-mode eye pass of `set` (`records`, and `out` with its direct values
    /// without the area-light term) and `maps`' accumulated map: the ladder's outer disc has
    /// kOuterArea × the area of the map's k-NN disc (within rMax), its rings get the map's
    /// photons within it. Fills `out`.
    /// Cost: one k-NN gather and one radius search per hit.
    void restart(const EmbreeScene& scene, const PhotonMaps& maps, uint32_t set, const Camera& camera,
                 EyeRecords records, std::span<PixelRadiance> out);
    /// One pass, after maps.shootPass(scene, set, b): bins the pass's photons per hit, and those
    /// of every other set in `shared` (their shots of kSharedPhotonLag frames ago and of the
    /// frames since the set's last turn, one index per frame; may be empty), adds one area-light
    /// sample set per hit, and
    /// writes every pixel's current estimate to `out`. Precondition: valid(). Adds the shadow
    /// rays cast to `shadowRays`; counts non-finite pixel values (replaced by 0) in `nonFinite`.
    void pass(const EmbreeScene& scene, const PhotonMaps& maps, uint32_t set,
              std::span<const SharedPhotons* const> shared,
              const AreaLightSampler& areaLights, std::span<PixelRadiance> out, uint64_t& shadowRays,
              uint64_t& nonFinite);
    /// A pass off the set's turn (pass_budget.h passShoots): counts the pass and writes the
    /// pixels of the last composed frame to `out`, bit for bit; no photon is binned and no ray
    /// cast (the photons the other sets shared meanwhile are binned at the set's next turn).
    /// Precondition: valid().
    void skip(std::span<PixelRadiance> out);

    /// The discs the rule chooses for one hit's rings (exposed for tests).
    struct Choice {
        int disc = 0;            ///< index into the ladder
        /// r² of the shown disc relative to the ladder's outer disc: kBinRatio2^disc, or between
        /// disc and the next wider one where the cap ends the walk inside a ring (its photons
        /// taken as spread evenly over the ring's area, up to exactly maxCount photons).
        double scale = 1.0;
        glm::dvec3 power{0.0};   ///< Σ power within it (W, summed over batches)
        double count = 0.0;      ///< photons within it
        /// The disc's blur relative to E: from the step to the disc admitted just inside it (E',
        /// 0 when none), √max(0, ((E − E')² − Var(E − E'))/E²) / (1 − kBinRatio2), the step's
        /// Poisson noise taken out. A kernel's bias grows as r², so the step from
        /// r'² = kBinRatio2 r² to r² shows 1 − kBinRatio2 of disc j's own bias.
        double drift = 0.0;
        /// Equal-power photons as noisy as those within it, (Σw)²/Σw² with w a photon's
        /// luminance: σ ≈ E/√effective (count where every photon carries one power).
        double effective = 0.0;
        /// The cap (maxDiscPhotons) ended the walk: the disc holds exactly maxCount photons.
        bool capped = false;
    };
    /// The shape of a hit's discs (kShapePhotons): circles until the photons around it decide,
    /// then fixed for the progression.
    struct Shape {
        Vec3 across{0.0f};    ///< an ellipse's short axis (unit, in the surface)
        float aspect = 1.0f;  ///< semi-axes r/√aspect across, r√aspect along (area π r²); 1: a circle
        bool decided = false;
        /// Until decided: the photons binned and the sums of their offsets' coordinates (and
        /// products) along two axes of the surface.
        float n = 0.0f, s1 = 0.0f, s2 = 0.0f, s11 = 0.0f, s12 = 0.0f, s22 = 0.0f;
    };
    struct Rings {
        std::array<float, kRadiusBins * 3> power{};  ///< Σ power per ring (W summed over batches)
        std::array<float, kRadiusBins> count{};      ///< photons per ring
        /// Σ squared luminance of the photons' power in the maps' power unit (a photon's is < 2
        /// units, so the squares keep float's range whatever the lights' watts; choose's powerUnit)
        std::array<float, kRadiusBins> power2{};
    };
    /// The intersection-of-confidence-intervals choice over rings `active` … kRadiusBins−1 of a
    /// ladder: the discs' estimates differ only by their area, so the rule needs no radius. σ is
    /// multiplied by `noiseScale[i]` for choice i (two choices from one walk over the rings).
    /// `powerUnit`: the maps' power unit (PhotonMaps::powerUnit), in which Rings::power2 is kept.
    static void choose(const Rings& rings, int active, double gamma, const double (&noiseScale)[2],
                       double maxCount, Choice (&out)[2], double powerUnit = 1.0);
    /// Adds one pass's photons (squared distance from the end point, power) to the rings of a
    /// ladder whose outer disc has squared radius `outer2`: a photon with r_{j+1}² ≤ d² < r_j² to
    /// ring j (the innermost ring holds the whole innermost disc); rings inside `active` are no
    /// longer kept and take nothing. A photon beyond the outer disc counts in ring 0: pass such
    /// photons only with `active` > 0, which leaves them out (the restart bins what a wider search
    /// found that way). Exposed for tests.
    static void bin(Rings& rings, float outer2, int active, std::span<const FoundPhoton> photons,
                    float powerUnit = 1.0f);
    /// bin of what radius searches of `trees` (in that order) find: their photons strictly within
    /// sqrt(radius2) of `x` arriving from the front of `normal` (and, given `visible`, visible
    /// from the end point), stored powers × `treeUnit` (W), binned as the searches find them —
    /// the same rings, bit for bit, as one bin of the lists RadiusList searches of the same trees
    /// give, without the lists (a pass: its own photons, then the other sets' shared shots).
    /// Photons of a tagged tree (SharedPhotons) whose tag is `set` are left out: the set's own.
    /// With `shape`: an ellipse's rings take the photons within the ellipses (the same area), and
    /// while the shape is undecided the photons binned add to its moments and may decide it.
    static void binWithin(Rings& rings, float outer2, int active, std::span<const KdTree* const> trees, uint32_t set,
                          Vec3 x, Vec3 normal, float radius2, float treeUnit, float powerUnit = 1.0f,
                          const VisibleFrom* visible = nullptr, Shape* shape = nullptr);

private:
    struct HitState {
        Rings rings;
        float outer2 = 0.0f;       ///< R₀² (m²): the ladder's outer disc
        int active = 0;            ///< outermost ring still gathered
        glm::dvec3 areaSum{0.0};   ///< Σ area-light samples over passes 0 … t
        float shared = 0.0f;       ///< other sets' batches binned (SharedPhotons)
        Shape shape;               ///< circles or ellipses
        bool sharing = false;      ///< bins the other sets' photons (its pixel shows its own estimate)
    };
    void compose(std::span<PixelRadiance> out, uint64_t& nonFinite);

    bool valid_ = false;
    Camera camera_;
    uint32_t passes_ = 0;
    uint32_t areaSets_ = 0;  ///< area-light sample sets added by passes (the restart's is one more)
    double batches_ = 0.0;
    /// What the rule reads besides the rings: the settings at the restart and the filter's share.
    struct Rule {
        double gamma = 2.0;             ///< Γ of the settings
        uint32_t k = 64;                ///< the k-NN k of the settings (maxDiscPhotons)
        uint32_t pathsPerBatch = 20000; ///< P of the settings
        double filterShare = 1.0;       ///< setFilterShare
        double powerUnit = 1.0;         ///< PhotonMaps::powerUnit (Rings::power2's unit)
    } rule_;
    /// The image geometry of setImage.
    struct Image {
        int m = 1, f = 1, columns = 1;
    } image_;
    std::vector<uint8_t> ownWeights_;
    std::vector<uint8_t> noise_;
    std::vector<PixelRadiance> shown_;  ///< the pixels of the last compose (skip)
    EyeRecords records_;
    std::vector<HitState> state_;     ///< per hit
    std::vector<Vec3> fixedDirect_;   ///< per pixel: direct light but the area-light term
    CausticErrorSums error_;
};

}  // namespace rtpm
