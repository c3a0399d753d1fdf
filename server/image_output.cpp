// The master's output stage: pixel decoding, assembly, caustic filtering, composition, files.
#include "server/image_output.h"

#include <tbb/parallel_for.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "common/core/output_file.h"
#include "common/image/image_io.h"
#include "common/render/image_metadata.h"
#include "proto/bridge/bridge.h"
#include "proto/pixel_codec.h"

namespace rtpm::server {

ImageOutput::ImageOutput(ImageOutputOptions options)
    : opt_(std::move(options)),
      pattern_{opt_.width, opt_.height, opt_.interleave},
      image_(opt_.width, opt_.height),
      radiance_(size_t(opt_.interleave) * size_t(opt_.interleave)),
      scattered_(radiance_.size()) {
    settings_.width = opt_.width;
    settings_.height = opt_.height;
    settings_.interleave = opt_.interleave;
    if (!opt_.csv.empty()) {
        const bool fresh = !std::filesystem::exists(opt_.csv);
        csv_ = std::fopen(opt_.csv.c_str(), "a");
        if (!csv_) throw OutputError("--csv " + opt_.csv + ": cannot open: " + std::strerror(errno));
        if (fresh)
            std::fprintf(csv_, "frame,fps,photons_per_set,mode,bytes,slowest_client,slowest_ms,sets_arrived,"
                               "sets_total,deadline_hit,master_ms,slowest_photon_ms,slowest_eye_ms,"
                               "slowest_encode_ms,est_error,pass_batches,pass_period\n");
    }
    thread_ = std::thread([this] { io_.run(); });
}

ImageOutput::~ImageOutput() {
    drain();
    if (csv_) std::fclose(csv_);
}

void ImageOutput::drain() {
    guard_.reset();
    if (thread_.joinable()) thread_.join();
}

void ImageOutput::post(OutputJob job, std::function<void(OutputResult)> done) {
    asio::post(io_, [this, job = std::move(job), done = std::move(done)]() mutable { done(process(job)); });
}

void ImageOutput::reconfigure(int interleave, int filter) {
    asio::post(io_, [this, interleave, filter] {
        opt_.interleave = interleave;
        opt_.filter = filter;
        pattern_ = Interleave{opt_.width, opt_.height, interleave};
        radiance_.assign(size_t(interleave) * size_t(interleave), {});
        scattered_.assign(radiance_.size(), {});
        composed_ = false;
    });
}

void ImageOutput::write(std::string exrPath, std::function<void(std::string error)> done) {
    asio::post(io_, [this, exrPath = std::move(exrPath), done = std::move(done)] {
        try {
            writeImages(exrPath);
            done("");
        } catch (const std::exception& e) {
            done(e.what());
        }
    });
}

OutputResult ImageOutput::process(OutputJob& job) {
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    OutputResult result;
    std::vector<std::string> errors(job.data.size());
    std::vector<uint64_t> clamped(job.data.size(), 0);
    std::vector<uint8_t> unchanged(job.data.size(), 0);  // nothing to decode or scatter
    for (size_t i = 0; i < job.data.size(); ++i) {
        const proto::FrameData& d = job.data[i];
        if (!d.unchanged) continue;
        unchanged[i] = 1;
        const Scattered& last = scattered_[d.set];
        if (!(last.valid && last.frame == d.sameAs && last.pixelCount == d.pixelCount)) ++result.unmatchedUnchanged;
    }
    // Decoding is the master's heaviest step: sets decode in parallel, each straight into its
    // own radiance buffer (a set appears once per frame); scatter stays serial (FrameImage contract).
    tbb::parallel_for(size_t(0), job.data.size(), [&](size_t i) {
        if (unchanged[i]) return;
        const proto::FrameData& d = job.data[i];
        std::vector<PixelRadiance>& rad = radiance_[d.set];
        rad.resize(d.pixelCount);
        proto::Status st = proto::decodePixels(d.encoding, d.pixels, bridge::pixelView(std::span(rad)));
        if (!st.ok()) errors[i] = st.error().message;
        // Decoded values are finite and >= 0; a peer may still send 3e38, which overflows to +Inf
        // once direct and caustic are added or the box filter sums a window.
        for (PixelRadiance& p : rad)
            for (Vec3* v : {&p.direct, &p.caustic})
                for (int c = 0; c < 3; ++c)
                    if (!((*v)[c] <= kMaxPixelRadiance)) {
                        (*v)[c] = std::isfinite((*v)[c]) ? kMaxPixelRadiance : 0.0f;
                        ++clamped[i];
                    }
    });
    for (size_t i = 0; i < job.data.size(); ++i)
        if (clamped[i] > 0) {
            result.clampedValues += clamped[i];
            std::fprintf(stderr, "rtpm-server: frame %llu set %u from client %u: %llu radiance values above %g clamped\n",
                         (unsigned long long)job.data[i].frame, job.data[i].set, job.owners[job.data[i].set],
                         (unsigned long long)clamped[i], double(kMaxPixelRadiance));
        }
    for (size_t i = 0; i < job.data.size(); ++i) {
        const proto::FrameData& d = job.data[i];
        if (unchanged[i]) continue;
        Scattered& last = scattered_[d.set];
        last.valid = false;
        if (!errors[i].empty()) {
            result.badPayloads.emplace_back(job.owners[d.set], "frame " + std::to_string(d.frame) + " set " +
                                                                   std::to_string(d.set) +
                                                                   ": bad pixel payload: " + errors[i]);
            continue;
        }
        // Each pixel's own caustic gets the weight its client chose against the box filter
        // (progressive.h); none for knn (the decoder checked the count).
        if (d.ownWeights.empty()) image_.scatter(pattern_, static_cast<int>(d.set), radiance_[d.set]);
        else image_.scatter(pattern_, static_cast<int>(d.set), radiance_[d.set], d.ownWeights, d.noise);
        composed_ = false;
        last = Scattered{true, d.frame, d.pixelCount};
    }
    // A frame that scattered nothing (every set off its turn, or none arrived) shows the image
    // composed before: filtering it again would give the same bits.
    // The edge ratio is a live knob of the output stage alone: a change of it filters again.
    const float edgeRatio = job.settings.filterEdgeRatio();
    if (!composed_ || edgeRatio != composedEdgeRatio_) image_.filterAndCompose(opt_.filter, edgeRatio);
    composed_ = true;
    composedEdgeRatio_ = edgeRatio;
    const double change = change_.add(job.mode == proto::FrameMode::Converging, job.passPeriod, job.estimateBatches,
                                      image_.causticFiltered(), image_.width(), image_.height());
    result.errorEstimate = shownErrorFigure(job.errorEstimate, change);
    result.masterMs = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    shown_ = job.shown;
    photonsStored_ = uint64_t(std::llround(job.photonsPerSet * double(job.setCount)));
    settings_ = job.settings;
    if (opt_.onComposed) opt_.onComposed(job.frame, image_);
    try {
        if (!job.saveAs.empty()) writeImages(job.saveAs);
        if (job.last && !opt_.out.empty()) writeImages(opt_.out);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "rtpm-server: cannot write images: %s\n", e.what());
        result.writeFailed = true;
    }
    if (!opt_.quiet) {
        progress_.clear();
        // The estimated error and the pass size, when they say something.
        char extra[64] = "";
        if (result.errorEstimate > 0.0)
            std::snprintf(extra, sizeof extra, "  est. error %.4f", result.errorEstimate);
        if (job.passBatches > 1)
            std::snprintf(extra + std::strlen(extra), sizeof extra - std::strlen(extra), "  batches %u",
                          job.passBatches);
        if (job.passPeriod > 1)
            std::snprintf(extra + std::strlen(extra), sizeof extra - std::strlen(extra), "  sets shoot 1 pass in %u",
                          job.passPeriod);
        std::printf("frame %5llu  %7.2f fps  %-11s  photons/set %10.0f  sets %3zu/%-3u  %8.2f MB  "
                    "slowest %s %.1f ms  master %.2f ms%s%s\n",
                    (unsigned long long)job.frame, job.fps, proto::frameModeName(job.mode), job.photonsPerSet,
                    job.arrived, job.setCount, double(job.bytes) / 1e6, job.slowest.c_str(), job.slowestMs,
                    result.masterMs, job.deadlineHit ? "  (deadline)" : "", extra);
        std::fflush(stdout);
        // i/N, elapsed and ETA on stderr: on a terminal always; otherwise only for a finite run
        // (a service's plain log is the frame line above, not a stderr line a second forever).
        if (progress_.terminal() || opt_.totalFrames > 0) {
            progress_.update(job.shown, opt_.totalFrames, job.elapsedSeconds);
            if (job.last) progress_.finish();
        }
    }
    if (csv_) {
        std::fprintf(csv_, "%llu,%.3f,%.1f,%s,%llu,%s,%.3f,%zu,%u,%d,%.3f,%.3f,%.3f,%.3f,%.5f,%u,%u\n",
                     (unsigned long long)job.frame, job.fps, job.photonsPerSet, proto::frameModeName(job.mode),
                     (unsigned long long)job.bytes, job.slowest.c_str(), job.slowestMs, job.arrived,
                     job.setCount, job.deadlineHit ? 1 : 0, result.masterMs, job.slowestPhotonMs,
                     job.slowestEyeMs, job.slowestEncodeMs, result.errorEstimate, job.passBatches,
                     job.passPeriod);
        std::fflush(csv_);
    }
    return result;
}

void ImageOutput::writeImages(const std::string& exrPath) {
    const std::filesystem::path dir = std::filesystem::path(exrPath).parent_path();
    if (!dir.empty()) std::filesystem::create_directories(dir);
    const std::string png = writeImageFiles(exrPath, image_, provenance());
    progress_.clear();
    std::fprintf(stderr, "rtpm-server: wrote %s and %s\n", exrPath.c_str(), png.c_str());
}

ImageProvenance ImageOutput::provenance() const {
    return {"rtpm-server", opt_.sceneName, settings_, shown_, photonsStored_};
}

}  // namespace rtpm::server
