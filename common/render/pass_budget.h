// How much a still frame shoots: passes grow while the view stays still, up to a frame-time
// budget, and shrink below one batch per set when one batch per set costs more than the budget.
#pragma once

#include <algorithm>
#include <cstdint>

#include "common/core/render_settings.h"

namespace rtpm {

/// Whether set `set` of `sets` shoots in its progression's pass number `pass` (1 for the first
/// pass after its restart) when the sets take turns every `period` passes (PassBudget::period):
/// the sets fall into `period` groups of neighbouring ids, g = ⌊set · period / sets⌋, and group g
/// shoots in the passes with (pass + g) mod period = 0 — each set once per period. Neighbouring
/// ids, not every period-th one: clients get sets round robin, so a group of neighbours spreads
/// a frame's shooting over the clients where a residue class would give it all to one.
/// The other sets' passes bin only the photons the others shared (progressive.h).
inline bool passShoots(uint64_t pass, uint32_t set, uint32_t sets, uint32_t period) {
    if (period <= 1 || sets == 0) return true;
    const uint64_t group = uint64_t(set) * period / sets;
    return (pass + group) % period == 0;
}

/// Work of the next frame's progressive passes: `batches` per set and pass, and the sets taking
/// turns every `period` frames. A frame that moves (camera, edit, restart) resets both to 1, so
/// motion stays as cheap as the settings make it. While frames converge the work doubles
/// whenever a frame took less than half the budget (first the period halves, then the batches
/// double) and halves when one took more than the budget (first the batches, then the period
/// doubles, where shooting is at least half of the frame; while the sets take turns, the means
/// over a whole turn decide). So a still view does ever more work per frame while the viewer
/// still gets 1/budget updates a second, and a scene whose single batch per set costs more than
/// the budget (costly photon paths) still updates at about that rate, not slower than a frame
/// that moves. A budget of 0 keeps one batch per set and pass (deterministic: the frame sequence
/// does not depend on the machine's speed). Pure: the caller measures time.
class PassBudget {
public:
    explicit PassBudget(double budgetSeconds = 0.0) : budget_(budgetSeconds) {}

    /// Batches the next frame's passes shoot, in [1, kMaxPassBatches].
    uint32_t batches() const { return batches_; }
    /// Frames between two shooting passes of a set, in [1, kMaxPassPeriod] (passShoots); > 1
    /// only while batches() is 1.
    uint32_t period() const { return period_; }
    /// After a frame: whether it was a progressive pass (converging), how long it took and how
    /// much of that was shooting photons.
    void record(bool converging, double frameSeconds, double shootSeconds) {
        if (!converging || !(budget_ > 0.0)) {
            batches_ = 1;
            period_ = 1;
            turnSeconds_ = turnShootSeconds_ = 0.0;
            turnFrames_ = 0;
            return;
        }
        // While the sets take turns a frame's cost depends on whose turn it is: decide on the
        // mean over one whole turn (period frames).
        turnSeconds_ += frameSeconds;
        turnShootSeconds_ += shootSeconds;
        if (++turnFrames_ < period_) return;
        frameSeconds = turnSeconds_ / double(turnFrames_);
        shootSeconds = turnShootSeconds_ / double(turnFrames_);
        turnSeconds_ = turnShootSeconds_ = 0.0;
        turnFrames_ = 0;
        if (frameSeconds < 0.5 * budget_) {
            if (period_ > 1) period_ /= 2;
            else batches_ = std::min(kMaxPassBatches, batches_ * 2);
        } else if (frameSeconds > budget_) {
            if (batches_ > 1) batches_ = std::max(1u, batches_ / 2);
            // Turns pay only where shooting is most of the frame: elsewhere (the eye pass and the
            // binning dominate) fewer photons would barely shorten it.
            else if (shootSeconds >= 0.5 * frameSeconds) period_ = std::min(kMaxPassPeriod, period_ * 2);
        }
    }

private:
    double budget_;
    uint32_t batches_ = 1;
    uint32_t period_ = 1;
    double turnSeconds_ = 0.0;       ///< Σ frame seconds of the current turn
    double turnShootSeconds_ = 0.0;  ///< Σ of their shooting seconds
    uint32_t turnFrames_ = 0;        ///< frames of the current turn recorded
};

}  // namespace rtpm
