// The master's image output stage: decode → scatter → filter → compose → write, on its own thread.
#pragma once

#include <asio.hpp>

#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "common/core/interleave.h"
#include "common/core/pixel_radiance.h"
#include "common/core/progress.h"
#include "common/core/render_settings.h"
#include "common/image/image_io.h"
#include "common/render/image_metadata.h"
#include "common/image/frame_image.h"
#include "common/image/shown_change.h"
#include "proto/messages.h"
#include "server/assignment.h"

namespace rtpm::server {

/// Where and how the output stage writes.
struct ImageOutputOptions {
    int width = 640, height = 480, interleave = 3, filter = 3;
    std::string out;   ///< final EXR (PNG beside it); empty = none
    std::string csv;   ///< per-frame figures, appended (header when new); empty = none
    bool quiet = false;  ///< no per-frame line on stdout and no progress line on stderr
    std::string sceneName;  ///< as given (--scene), for the images' metadata
    uint64_t totalFrames = 0;  ///< frames of the run, for the progress line (0 = until stopped)
    /// Called on the output thread after each frame is composed, before files are written (the
    /// browser viewer's feed). Must not keep the reference.
    std::function<void(uint64_t frame, const FrameImage& image)> onComposed;
};

/// One retired frame and its figures, handed from the frame loop to the output stage.
struct OutputJob {
    uint64_t frame = 0;
    proto::FrameMode mode{};
    double fps = 0.0;
    uint64_t bytes = 0;
    double photonsPerSet = 0.0;
    std::string slowest;
    float slowestMs = 0.0f;
    /// The slowest client's split of its frame: shooting + insertion, eye pass, encoding (ms).
    float slowestPhotonMs = 0.0f, slowestEyeMs = 0.0f, slowestEncodeMs = 0.0f;
    size_t arrived = 0;
    uint32_t setCount = 0;
    bool deadlineHit = false;
    std::vector<ClientId> owners;  ///< owner per set at this frame, to name bad payloads
    std::vector<proto::FrameData> data;
    std::string saveAs;  ///< also write this frame to this EXR path (PNG beside it); empty = no
    bool last = false;   ///< write opt.out after this frame
    double errorEstimate = 0.0;  ///< progressive: the caustic's estimated relative error (0 = none)
    /// Progressive: Σ over the sets of the batches in their estimates (0 = unknown: not every
    /// set arrived), how far the progression went (shown_change.h).
    double estimateBatches = 0.0;
    uint32_t passBatches = 1;    ///< batches per set this frame's progressive passes shot
    uint32_t passPeriod = 1;     ///< the sets took turns: one pass in this many shot (pass_budget.h)
    bool cameraStill = false;    ///< the frame's camera was the previous frame's (Convergence)
    uint64_t shown = 0;  ///< frames shown so far, this one included
    double elapsedSeconds = 0.0;  ///< since the first frame began
    RenderSettings settings;      ///< the settings this frame was rendered with (image metadata)
};

/// What the output stage found.
struct OutputResult {
    std::vector<std::pair<ClientId, std::string>> badPayloads;  ///< client, why
    double masterMs = 0.0;  ///< decode + scatter + filter + compose
    bool writeFailed = false;
    uint64_t clampedValues = 0;  ///< decoded radiance values above kMaxPixelRadiance, clamped
    /// The caustic's estimated relative error as shown and written: the shown caustic's change
    /// since a sixth of the progression's photons, scaled (shown_change.h), where the job's own figure
    /// (OutputJob::errorEstimate) says the progressive estimator composed the frame; 0 = none
    /// (knn, moving frames, and a progression's frames before an image of a third of its photons).
    double errorEstimate = 0.0;
    /// FrameData of unchanged pixels (FrameData::unchanged) whose frame's pixels this stage did not
    /// show (that frame's data came late or not at all): the set keeps what it shows.
    uint64_t unmatchedUnchanged = 0;
};

/// Largest radiance (W/(m²·sr)) the master accepts from a client; larger values are clamped and
/// counted. Far above anything a scene within the rules of common/scene/scene.h produces, and
/// low enough that direct + caustic and the box filter's window sums stay finite.
constexpr float kMaxPixelRadiance = 1e30f;

/// Decodes each set's pixels straight into its radiance buffer (sets in parallel), scatters them
/// into the full frame, box-filters the caustics, composes and writes EXR + PNG and the CSV row.
/// post() runs jobs in order on the stage's own thread, so a slow frame never stalls the sockets;
/// process() runs one on the caller's thread. Sets missing from a job keep their previous values,
/// as do sets whose FrameData says their pixels are unchanged.
class ImageOutput {
public:
    /// Throws std::runtime_error if the CSV file cannot be opened.
    explicit ImageOutput(ImageOutputOptions options);
    ~ImageOutput();  ///< finishes queued jobs, then joins the thread
    ImageOutput(const ImageOutput&) = delete;
    ImageOutput& operator=(const ImageOutput&) = delete;

    /// Queues `job`; `done` is called on the output thread with its result.
    void post(OutputJob job, std::function<void(OutputResult)> done);
    /// Queues a change of M and F (a settings edit): jobs queued after it use the new pattern.
    void reconfigure(int interleave, int filter);
    /// Queues writing the current image to `exrPath` (PNG beside it); `done` gets "" or the error,
    /// on the output thread.
    void write(std::string exrPath, std::function<void(std::string error)> done);
    /// Finishes every queued job and stops the thread; later post()s are not run. Idempotent.
    void drain();
    /// Runs `job` on the calling thread. Not concurrent with post()ed jobs.
    OutputResult process(OutputJob& job);
    const FrameImage& image() const { return image_; }

private:
    void writeImages(const std::string& exrPath);
    /// What made the image, as of the last processed job (image_metadata.h).
    ImageProvenance provenance() const;

    ImageOutputOptions opt_;
    Interleave pattern_;
    FrameImage image_;
    float composedEdgeRatio_ = 0.0f;  ///< the edge ratio image_ was last filtered with
    bool composed_ = false;  ///< image_ is filtered and composed from everything scattered into it
    std::vector<std::vector<PixelRadiance>> radiance_;  ///< per set, reused
    /// Per set, the frame whose payload was last scattered into the image: a FrameData of
    /// unchanged pixels that names it (a set off its turn) needs nothing, the image holds them.
    struct Scattered {
        bool valid = false;
        uint64_t frame = 0;
        uint32_t pixelCount = 0;
    };
    std::vector<Scattered> scattered_;
    ShownChange change_;  ///< the still view's error figure from the shown caustic
    FILE* csv_ = nullptr;
    ProgressLine progress_{stderr, isTerminal(stderr)};
    uint64_t shown_ = 0;             ///< of the last processed job
    uint64_t photonsStored_ = 0;     ///< of the last processed job, all sets
    RenderSettings settings_;        ///< of the last processed job
    asio::io_context io_;
    asio::executor_work_guard<asio::io_context::executor_type> guard_{io_.get_executor()};
    std::thread thread_;
};

}  // namespace rtpm::server
