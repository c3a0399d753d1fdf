// A still view's convergence on the master: how many batches a progressive pass shoots (the
// frame-time budget) and whether the estimated caustic error reached --target-error.
#pragma once

#include <cstdint>

#include "common/render/pass_budget.h"
#include "proto/messages.h"

namespace rtpm::server {

/// Pure: the frame loop passes what it measured. Not thread-safe.
class Convergence {
public:
    /// `frameBudgetMs`: the frame time passes grow to (0 = one batch per pass); `targetError`:
    /// the estimated error that ends the run (0 = never).
    Convergence(double frameBudgetMs, double targetError)
        : budget_(frameBudgetMs * 1e-3), targetError_(targetError) {}

    /// Batches each set shoots in a frame of `mode`: the budget's for a Converging frame, else one.
    uint32_t batchesFor(proto::FrameMode mode) const {
        return mode == proto::FrameMode::Converging ? budget_.batches() : 1u;
    }
    /// Frames between two shooting passes of a set in a frame of `mode` (PassBudget::period): the
    /// budget's for a Converging frame, else one.
    uint32_t periodFor(proto::FrameMode mode) const {
        return mode == proto::FrameMode::Converging ? budget_.period() : 1u;
    }
    /// A shown frame of `mode` whose slowest client worked `workMs` (shooting, eye pass, encoding;
    /// not the wait behind the frame before) adapts the budget.
    void recordWork(proto::FrameMode mode, double workMs) {
        budget_.record(mode == proto::FrameMode::Converging, workMs * 1e-3);
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

private:
    PassBudget budget_;
    double targetError_;
    bool reached_ = false;
};

}  // namespace rtpm::server
