// RenderThread: a session's queue of Settings, Scene, Edit and FrameBegin, rendered in order on its own thread.
#include "client/render_thread.h"

#include <algorithm>
#include <cstdio>

namespace rtpm::client {

namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

std::string setList(const std::vector<uint32_t>& sets) {
    std::string s;
    for (uint32_t v : sets) {
        if (!s.empty()) s += ',';
        s += std::to_string(v);
    }
    return s.empty() ? "none" : s;
}

RenderThread::RenderThread(uint64_t session, uint32_t threads, double slowdown, bool verbose, RenderSink& sink,
                           std::atomic<uint64_t>& framesRendered)
    : session_(session), verbose_(verbose), sink_(sink), framesRendered_(framesRendered), renderer_(threads, slowdown),
      thread_([this] { loop(); }) {}

RenderThread::~RenderThread() {
    stop();
    join();
}

void RenderThread::push(RenderItem item) {
    {
        std::lock_guard<std::mutex> lock(mu_);
        queue_.push_back(std::move(item));
    }
    cv_.notify_one();
}

void RenderThread::stop() {
    {
        std::lock_guard<std::mutex> lock(mu_);
        stop_ = true;
    }
    cv_.notify_all();
}

void RenderThread::join() {
    if (thread_.joinable()) thread_.join();
}

void RenderThread::loop() {
    struct Finished {
        std::atomic<bool>& flag;
        ~Finished() { flag = true; }
    } finished{finished_};
    for (;;) {
        RenderItem item;
        {
            std::unique_lock<std::mutex> lock(mu_);
            cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
            if (stop_) return;
            item = std::move(queue_.front());
            queue_.pop_front();
        }
        try {
            render(item);
        } catch (const ProtocolViolation& e) {
            return sink_.renderFailed(session_, RenderSink::Failure::Protocol, e.what());
        } catch (const SceneError& e) {
            return sink_.renderFailed(session_, RenderSink::Failure::Protocol, e.what());
        } catch (const std::exception& e) {
            return sink_.renderFailed(session_, RenderSink::Failure::Internal, e.what());
        }
    }
}

void RenderThread::render(RenderItem& item) {
    if (auto* st = std::get_if<proto::Settings>(&item)) return renderer_.setSettings(*st);
    if (auto* e = std::get_if<proto::Edit>(&item)) return renderer_.queueEdit(*e);
    if (auto* sc = std::get_if<proto::Scene>(&item)) {
        const auto t0 = Clock::now();
        renderer_.setScene(*sc);
        std::fprintf(stderr, "rtpm-client: scene %s loaded in %.0f ms\n",
                     sc->source == proto::Scene::Source::Builtin ? sc->builtinName.c_str() : "(glTF)",
                     std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        return;
    }
    const FrameItem& f = std::get<FrameItem>(item);
    RenderedFrame r = renderer_.render(f.begin, f.received);
    std::vector<std::vector<uint8_t>> bytes;
    for (const proto::FrameData& d : r.data) {
        auto enc = proto::tryEncode(d);
        if (!enc.ok())
            throw std::runtime_error("set " + std::to_string(d.set) +
                                     " does not fit one FrameData: " + enc.error().message);
        bytes.push_back(std::move(enc.value()));
    }
    bytes.push_back(proto::encode(r.stats));
    ++framesRendered_;
    if (verbose_) {
        std::printf("frame %llu: sets %s, photons %.1f ms, eye %.1f ms, encode %.1f ms, %llu stored\n",
                    (unsigned long long)f.begin.frame, setList(f.begin.sets).c_str(), double(r.stats.photonMs),
                    double(r.stats.renderMs), double(r.stats.encodeMs), (unsigned long long)r.stats.photonsStored);
        std::fflush(stdout);  // scripts and tests follow progress live
    }
    sink_.frameRendered(session_, std::move(bytes));
}

void RenderThreads::start(uint64_t session, uint32_t threads, double slowdown, bool verbose, RenderSink& sink,
                          std::atomic<uint64_t>& framesRendered) {
    // Earlier sessions' photon maps are freed, not kept for the run.
    std::erase_if(retired_, [](const std::unique_ptr<RenderThread>& t) {
        if (!t->finished()) return false;
        t->join();
        return true;
    });
    current_ = std::make_unique<RenderThread>(session, threads, slowdown, verbose, sink, framesRendered);
}

void RenderThreads::retire() {
    if (!current_) return;
    current_->stop();
    retired_.push_back(std::move(current_));
}

void RenderThreads::joinAll() {
    retire();
    for (auto& t : retired_) t->join();
    retired_.clear();
}

}  // namespace rtpm::client
