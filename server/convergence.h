// A still view's convergence on the master: how many batches a progressive pass shoots (the
// frame-time budget) and whether the estimated caustic error reached --target-error; and budgets
// for Accumulate frames, whose sets take turns shooting their batch when one batch per set costs
// more than the budget: the frame budget for a still camera (the knn estimator's still view), and
// kOrbitBudgetFactor × it for a moving one (a camera orbiting over costly photon paths).
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "common/render/pass_budget.h"
#include "proto/messages.h"

namespace rtpm::server {

/// Pure: the frame loop passes what it measured. Not thread-safe.
class Convergence {
public:
    /// `frameBudgetMs`: the frame time passes grow to (0 = one batch per pass); `targetError`:
    /// the estimated error that ends the run (0 = never).
    Convergence(double frameBudgetMs, double targetError)
        : frameBudgetMs_(frameBudgetMs), budget_(frameBudgetMs * 1e-3),
          accumulate_(frameBudgetMs * 1e-3, /*growBatches=*/false),
          orbit_(orbitBudgetMs(frameBudgetMs) * 1e-3, /*growBatches=*/false), targetError_(targetError) {}

    /// An orbit's Accumulate frames take turns only beyond kOrbitBudgetMs, or this many frame
    /// budgets where that is more: a set off its turn shoots nothing, and a moving camera's frames
    /// are what grows the map the moving image shows, so its frames keep every set shooting as
    /// they did when the budget was 200 ms for every frame; a still view's frames lose nothing to
    /// turns (progressive) or show the set's last pixels (knn) and follow the budget itself.
    static constexpr double kOrbitBudgetFactor = 4.0;
    static constexpr double kOrbitBudgetMs = 200.0;
    /// The orbit's budget for a frame budget of `frameBudgetMs` (0 stays 0: no turns).
    static double orbitBudgetMs(double frameBudgetMs) {
        return frameBudgetMs > 0.0 ? std::max(kOrbitBudgetMs, kOrbitBudgetFactor * frameBudgetMs) : 0.0;
    }

    /// Batches each set shoots in a frame of `mode`: the budget's for a Converging frame, else one.
    uint32_t batchesFor(proto::FrameMode mode) const {
        return mode == proto::FrameMode::Converging ? budget_.batches() : 1u;
    }
    /// Frames between two shooting passes of a set in a frame of `mode` (PassBudget::period): the
    /// pass budget's for a Converging frame, an accumulation budget's for an Accumulate frame
    /// (`still`: the camera's, else the orbit's; a set then shoots its batch in the frames
    /// passShoots(frame, set, …) names), else one.
    uint32_t periodFor(proto::FrameMode mode, bool still) const {
        if (mode == proto::FrameMode::Converging) return budget_.period();
        if (mode != proto::FrameMode::Accumulate) return 1u;
        return still ? accumulate_.period() : orbit_.period();
    }
    /// A shown frame of `mode` (`still`: at the previous frame's camera), planned with `period`
    /// (FrameBegin's passPeriod), whose slowest client worked `workMs` (shooting, eye pass,
    /// encoding; not the wait behind the frame before) adapts the budget (PassBudget::recordFrame:
    /// frames planned before its last change of turns are not counted).
    /// `shootMs`: the slowest client's shooting in that frame; a frame in which every set shot
    /// one batch (an epoch's first, an edit, an Accumulate frame without turns) predicts the
    /// next still view's first period (PassBudget::expectShooting), and with `workMs` the first
    /// period of a still camera's Accumulate frames (PassBudget::expectFrame).
    void recordWork(proto::FrameMode mode, bool still, double workMs, uint32_t period, double shootMs = 0.0) {
        using M = proto::FrameMode;
        const bool accumulate = mode == M::Accumulate;
        noteMotion(mode, still, workMs);
        if (mode == M::Interaction || mode == M::Edit || mode == M::Relight || (accumulate && period == 1)) {
            budget_.expectShooting(shootMs * 1e-3);
            accumulate_.expectFrame(workMs * 1e-3, orbit_.budget());
        }
        budget_.recordFrame(mode == proto::FrameMode::Converging, workMs * 1e-3, period);
        accumulate_.recordFrame(accumulate && still, workMs * 1e-3, period);
        orbit_.recordFrame(accumulate && !still, workMs * 1e-3, period);
    }
    /// True once, for the first Converging frame whose estimated error (> 0) is at most the target.
    bool reachesTarget(proto::FrameMode mode, double errorEstimate) {
        if (targetError_ <= 0.0 || mode != proto::FrameMode::Converging || !(errorEstimate > 0.0) ||
            errorEstimate > targetError_ || reached_)
            return false;
        reached_ = true;
        return true;
    }
    /// The target was reached: a run stopped by it is complete.
    bool reached() const { return reached_; }
    double targetError() const { return targetError_; }

    /// The frame time a still view is held to now: the frame budget, or less where the view
    /// moved faster just before it stood still (the median work of the last kMotionFrames moving
    /// frames, at least kMinStillMs): a still frame costs no more than a moving one.
    double stillBudgetMs() const { return budget_.budget() * 1e3; }

    static constexpr size_t kMotionFrames = 5;
    static constexpr double kMinStillMs = 10.0;

private:
    /// A frame that moved (an orbit's Accumulate or Walkthrough frame, an Edit or Relight frame;
    /// not an epoch's first, which builds maps) sets the still budgets to its recent work.
    void noteMotion(proto::FrameMode mode, bool still, double workMs) {
        using M = proto::FrameMode;
        const bool moved = mode == M::Edit || mode == M::Relight ||
                           ((mode == M::Accumulate || mode == M::Walkthrough) && !still);
        if (!moved || !(workMs > 0.0) || !(frameBudgetMs_ > 0.0)) return;
        motionMs_.push_back(workMs);
        if (motionMs_.size() > kMotionFrames) motionMs_.erase(motionMs_.begin());
        std::vector<double> sorted = motionMs_;
        std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(sorted.size() / 2), sorted.end());
        // Never above the budget, and not below kMinStillMs unless the budget itself is.
        const double ms = std::min(frameBudgetMs_, std::max(kMinStillMs, sorted[sorted.size() / 2]));
        budget_.setBudget(ms * 1e-3);
        accumulate_.setBudget(ms * 1e-3);
    }

    double frameBudgetMs_;
    std::vector<double> motionMs_;  ///< work of the last moving frames, oldest first
    PassBudget budget_;
    PassBudget accumulate_;  ///< still Accumulate frames: one batch per set at most, the period only
    PassBudget orbit_;       ///< moving Accumulate frames: the same, over kOrbitBudgetFactor × the budget
    double targetError_;
    bool reached_ = false;
};

}  // namespace rtpm::server
