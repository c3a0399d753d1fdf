// How much a still frame shoots: passes grow while the view stays still, up to a frame-time budget.
#pragma once

#include <algorithm>
#include <cstdint>

#include "common/core/render_settings.h"

namespace rtpm {

/// Batches per progressive pass for the next frame. A frame that moves (camera, edit, restart)
/// resets it to 1, so motion stays as cheap as the settings make it; while frames converge it
/// doubles whenever a frame took less than half the budget and halves when one took more
/// than the budget, so a still view does ever more work per frame while the viewer still gets
/// 1/budget updates a second. A budget of 0 keeps every pass at one batch (deterministic:
/// the frame sequence does not depend on the machine's speed). Pure: the caller measures time.
class PassBudget {
public:
    explicit PassBudget(double budgetSeconds = 0.0) : budget_(budgetSeconds) {}

    /// Batches the next frame's passes shoot.
    uint32_t batches() const { return batches_; }
    /// After a frame: whether it was a progressive pass (converging) and how long it took.
    void record(bool converging, double frameSeconds) {
        if (!converging || !(budget_ > 0.0)) {
            batches_ = 1;
            return;
        }
        if (frameSeconds < 0.5 * budget_) batches_ = std::min(kMaxPassBatches, batches_ * 2);
        else if (frameSeconds > budget_) batches_ = std::max(1u, batches_ / 2);
    }

private:
    double budget_;
    uint32_t batches_ = 1;
};

}  // namespace rtpm
