// How much a still frame does: passes grow while the view stays still, and the sets take turns
// where a frame would exceed the frame-time budget.
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
/// With more passes in a period than sets (period > sets), each set is its own group, g = set:
/// the sets shoot in consecutive passes (ids descending, so round-robin clients alternate) and
/// the passes without a set follow one another. Two frames are in flight at once (the master's
/// pipeline), so neighbouring passes on different clients run side by side and the empty ones
/// pass through together; spread between the sets (⌊set · period / sets⌋) every empty pass held
/// one of the two frames while one client's pass ran, and the other client waited.
/// A progressive pass off its set's turn shows the set's last pixels (ProgressiveSet::skip); an
/// Accumulate frame's set off its turn shoots nothing.
inline bool passShoots(uint64_t pass, uint32_t set, uint32_t sets, uint32_t period) {
    if (period <= 1 || sets == 0) return true;
    const uint64_t group = period > sets ? uint64_t(set) : uint64_t(set) * period / sets;
    return (pass + group) % period == 0;
}

/// Work of the next frame's progressive passes: `batches` per set and pass, and the sets taking
/// turns every `period` frames (a pass off its set's turn shows the set's last pixels; the photons
/// the other sets shared meanwhile are binned at its next turn, RenderJob). A frame that moves
/// (camera, edit, restart) resets both: the batches to 1, the period to the one the last batch
/// per set predicts (expectShooting; 1 without a prediction).
/// While frames converge, each decision takes the mean frame time over one whole turn (a frame's
/// cost depends on whose turn it is): above the budget the period doubles (a trial: unless its
/// first whole turn is at least 1 − kTurnGain faster than the turn before, it is undone and no
/// trial follows for kFirstTrialBackoff turns, twice as many after each further failure), and
/// while it may not, the batches halve; below half
/// the budget the batches double (a longer pass spreads a pass's fixed cost, its binning and
/// composing, over more photons). So a still view does ever more work per turn while the viewer
/// gets about 1/budget updates a second, and a scene whose single batch per set costs more than
/// the budget still updates at about that rate. With `growBatches` false (Accumulate frames,
/// whose batch is the map's growth step and whose sets off their turn shoot nothing) the batches
/// stay 1, turns begin only beyond kTurnStart × the budget and halve again below half of it.
/// A budget of 0 keeps one batch per set and no turns (deterministic: the frame sequence does not
/// depend on the machine's speed). Pure: the caller measures time.
class PassBudget {
public:
    /// `growBatches` false: the work never grows above one batch per set (only the period
    /// changes), as for Accumulate frames, whose batch is the map's growth step.
    explicit PassBudget(double budgetSeconds = 0.0, bool growBatches = true)
        : budget_(budgetSeconds), growBatches_(growBatches) {}

    /// The frame time the budget holds frames to (seconds; 0: one batch, no turns).
    double budget() const { return budget_; }
    /// Holds the frames to `seconds` from the next decision on, keeping the passes and turns
    /// reached so far (a budget of 0 stays 0: its frames must not depend on the machine's speed).
    void setBudget(double seconds) {
        if (budget_ > 0.0 && seconds > 0.0) budget_ = seconds;
    }
    /// The work of one batch per set in a frame that shot that (an epoch's first frame, an edit,
    /// an accumulating orbit): it predicts a pass's shooting, so a still view begun after it
    /// starts at the period that holds that to the budget (the power of two at or above
    /// seconds / budget, at most kMaxPassPeriod) instead of doubling from 1 turn by turn: on
    /// HEADLIGHT, whose batch per set costs 5 budgets, the first ten still frames ran at 2–8
    /// fps while the period doubled to 8. Takes effect at the next frame that starts the budget
    /// afresh. Only for progressive passes (growBatches); an accumulation budget has expectFrame.
    void expectShooting(double seconds) {
        if (growBatches_ && seconds > 0.0) predictPeriod(seconds);
    }
    /// For an accumulation budget (growBatches false): the work of a frame in which every set
    /// shot its batch and gathered its pixels again (an epoch's first frame, an edit, an
    /// Accumulate frame without turns) is what a still camera's Accumulate frame (the knn
    /// estimator's still view) costs without turns. Where that is more than `beyond` (the
    /// master: the orbit's budget, the most a moving frame is let cost before its sets take
    /// turns), the still view starts at the period that holds it to the budget instead of
    /// doubling from 1 turn by turn, whose first frames each cost more than any moving frame:
    /// HEADLIGHT's knn still view (515 ms for its first frame at the 16.7 ms budget) spent its
    /// first 20 frames at 1.9–18 fps, 10 fps over 40 frames against its walkthrough's 20. Below
    /// it the doubling is kept: it reaches its period within a few turns, and one set's turn per
    /// frame from the start shot 16–20 % fewer photons in RING's and EGG's first second. Takes
    /// effect at the next frame that starts the budget afresh.
    void expectFrame(double seconds, double beyond) {
        if (growBatches_ || !(seconds > 0.0)) return;
        predictPeriod(seconds > beyond && seconds > kTurnStart * budget_ ? seconds : 0.0);
    }
    /// Batches the next frame's passes shoot, in [1, kMaxPassBatches].
    uint32_t batches() const { return batches_; }
    /// Frames between two passes of a set, in [1, kMaxPassPeriod] (passShoots).
    uint32_t period() const { return period_; }
    /// After a frame of a pipelined loop (the master: frames are planned before the ones in
    /// flight are measured): `period` is what the frame was planned with. A frame of the budget's
    /// kind planned with another period than the budget's present one is stale — it ran before
    /// the last change of turns took effect — and is not counted: a doubled period's trial took in
    /// the frame still planned at the old period (HEADLIGHT: 645 ms beside the turn's 285 ms),
    /// missed the 1 − kTurnGain gain and was undone for good, leaving the still view at 1.8 fps
    /// where turns gave 8. Frames planned with other batch counts are counted: skipping them too
    /// made the passes grow only every third frame, and measured no better on the curved mirror.
    void recordFrame(bool converging, double frameSeconds, uint32_t period) {
        if (converging && budget_ > 0.0 && period != period_) return;
        record(converging, frameSeconds);
    }
    /// After a frame: whether it was a frame of the kind this budget sizes (a progressive pass, or
    /// for an accumulation budget an Accumulate frame) and how long it took; any other frame
    /// starts the budget afresh. For a loop that plans each frame after measuring the last one.
    void record(bool converging, double frameSeconds) {
        if (!converging || !(budget_ > 0.0)) {
            const uint32_t start = startPeriod_;
            *this = PassBudget(budget_, growBatches_);
            startPeriod_ = period_ = start;
            return;
        }
        // While the sets take turns a frame's cost depends on whose turn it is: decide on the
        // mean over one whole turn (period frames).
        turnSeconds_ += frameSeconds;
        if (++turnFrames_ < period_) return;
        const double mean = turnSeconds_ / double(turnFrames_);
        turnSeconds_ = 0.0;
        turnFrames_ = 0;
        if (blockedTurns_ > 0) --blockedTurns_;
        if (trialBefore_ > 0.0) {
            const bool paid = mean <= kTurnGain * trialBefore_;
            trialBefore_ = 0.0;
            if (!paid) {
                period_ /= 2;
                blockedTurns_ = backoff_;
                backoff_ = std::min(2 * backoff_, kMaxTrialBackoff);
                return;
            }
        }
        // Progressive passes (growBatches_): a set off its turn defers the photons shared with it
        // to its next turn (RenderJob), so turns cost no photon; they divide a frame's binning
        // and composing among the turns, and a longer pass per turn spreads its fixed cost over
        // more photons. Hence turns before smaller passes, and larger passes before fewer turns.
        // Accumulate frames (k-NN): a set off its turn shoots nothing, so turns cost photons.
        // (Without growBatches_ the batches stay 1.)
        const bool mayTurn = blockedTurns_ == 0 && period_ < kMaxPassPeriod &&
                             (period_ > 1 || growBatches_ || mean > kTurnStart * budget_);
        if (mean < 0.5 * budget_) {
            if (growBatches_ && batches_ < kMaxPassBatches) batches_ *= 2;
            else if (period_ > 1) period_ /= 2;
        } else if (mean > budget_) {
            if (mayTurn) {
                trialBefore_ = mean;
                period_ *= 2;
            } else if (batches_ > 1) {
                batches_ /= 2;
            }
        }
    }

    /// A doubled period stays only if its turns' mean frame time is at most this share of the
    /// mean before it.
    static constexpr double kTurnGain = 0.9;
    /// After a trial that did not pay, no other begins for this many whole turns, twice as many
    /// after each further failure (up to kMaxTrialBackoff), until the view moves. A failure for
    /// good would hold a still view at its period for as long as it stands when one turn's
    /// timing was merely unlucky: at the 16.7 ms budget, where a frame's time is a few
    /// milliseconds of noise, HEADLIGHT's knn still view stayed at 8 fps in one run of ten
    /// (the others reached the longest period and 86–95 fps), GLASS's still view at 36 fps
    /// against 109–116. Backing off keeps a scene whose turns never pay from trying every turn.
    static constexpr uint32_t kFirstTrialBackoff = 4;
    static constexpr uint32_t kMaxTrialBackoff = 64;
    /// Accumulate frames' turns begin only when the frames exceed the budget by this factor (once
    /// begun, the period doubles whenever a turn exceeds the budget). There turns buy frame rate
    /// with photons (a set off its turn shoots nothing), so frames near the budget keep every set
    /// shooting. (It applied to progressive passes too while their turns only saved the shooting:
    /// on the curved mirror, whose one-batch frames straddled a 200 ms budget, turns that came and
    /// went cost the cluster photons in its first frames, rel. MAE 0.0469 against 0.0434 after 8
    /// frames. Since a pass off its turn defers the shared photons, they begin at the budget.)
    static constexpr double kTurnStart = 1.25;

private:
    // The power of two at or above seconds / budget, at most kMaxPassPeriod (1 for 0 seconds).
    void predictPeriod(double seconds) {
        if (!(budget_ > 0.0)) return;
        uint32_t p = 1;
        while (seconds > 0.0 && p < kMaxPassPeriod && double(p) * budget_ < seconds) p *= 2;
        startPeriod_ = p;
    }

    double budget_;
    bool growBatches_ = true;
    uint32_t batches_ = 1;
    uint32_t period_ = 1;
    double turnSeconds_ = 0.0;   ///< Σ frame seconds of the current turn
    uint32_t turnFrames_ = 0;    ///< frames of the current turn recorded
    double trialBefore_ = 0.0;   ///< > 0 while a doubled period is on trial: the mean before it
    uint32_t blockedTurns_ = 0;  ///< turns before the next trial may begin (a trial did not pay)
    uint32_t backoff_ = kFirstTrialBackoff;  ///< what the next failed trial blocks
    uint32_t startPeriod_ = 1;   ///< the period a still view starts at (expectShooting)
};

}  // namespace rtpm
