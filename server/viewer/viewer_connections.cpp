// The viewers' WebSockets: per-viewer state, acknowledged frames, bounded status text.
#include "server/viewer/viewer_connections.h"

#include <nlohmann/json.hpp>

#include <algorithm>

namespace rtpm::server {

namespace {

/// Unsent bytes above which a viewer gets no more status text until it drains (frames are
/// flow-controlled by acknowledgements instead).
constexpr size_t kMaxBufferedBytes = 1u << 20;

}  // namespace

ViewerConnections::ViewerConnections(WsEndpoint& ws, const ViewerFrames& frames)
    : ws_(ws), frames_(frames) {}

void ViewerConnections::open(ConnId id) { viewers_.emplace(id, Viewer{}); }

bool ViewerConnections::close(ConnId id) { return viewers_.erase(id) > 0; }

Viewer* ViewerConnections::find(ConnId id) {
    auto it = viewers_.find(id);
    return it == viewers_.end() ? nullptr : &it->second;
}

void ViewerConnections::welcome(ConnId id, bool control) {
    Viewer* v = find(id);
    if (!v) return;
    v->helloed = true;
    v->control = control;
    sendText(id, nlohmann::json{{"type", "hello"}, {"control", v->control}}.dump());
    if (!scene_.empty()) sendText(id, scene_);
    if (!status_.empty()) sendText(id, status_);
}

void ViewerConnections::setDisplay(ConnId id, const DisplayKey& key) {
    Viewer* v = find(id);
    if (!v || key == v->key) return;
    v->key = key;
    v->lastSent = UINT64_MAX;
}

bool ViewerConnections::acknowledge(ConnId id, uint64_t frame) {
    Viewer* v = find(id);
    if (!v || !v->awaitingAck || frame != v->lastSent) return false;
    v->awaitingAck = false;
    return true;
}

std::vector<DisplayKey> ViewerConnections::displays() const {
    std::vector<DisplayKey> keys;
    for (const auto& [id, v] : viewers_)
        if (v.helloed && std::find(keys.begin(), keys.end(), v.key) == keys.end())
            keys.push_back(v.key);
    return keys;
}

bool ViewerConnections::waitingFor(const DisplayKey& key, uint64_t frame) const {
    for (const auto& [id, v] : viewers_)
        if (v.helloed && !v.awaitingAck && v.key == key && v.lastSent != frame) return true;
    return false;
}

void ViewerConnections::sendFrame(ConnId id) {
    Viewer* v = find(id);
    if (!v || !v->helloed || v->awaitingAck) return;
    const EncodedFrame* e = frames_.latest(v->key);
    if (!e || e->frame == UINT64_MAX || e->frame == v->lastSent) return;
    if (!ws_.send(id, e->message.data(), e->message.size(), true)) return;
    v->awaitingAck = true;
    v->lastSent = e->frame;
}

void ViewerConnections::sendFrames() {
    for (const auto& [id, v] : viewers_) sendFrame(id);
}

void ViewerConnections::sendText(ConnId id, const std::string& text, bool droppable) {
    if (droppable && ws_.buffered(id) > kMaxBufferedBytes) return;
    ws_.send(id, text.data(), text.size(), false);
}

void ViewerConnections::broadcast(const std::string& text, bool droppable) {
    for (const auto& [id, v] : viewers_)
        if (v.helloed) sendText(id, text, droppable);
}

void ViewerConnections::publishStatus(std::string json) {
    status_ = std::move(json);
    broadcast(status_, true);
}

void ViewerConnections::publishScene(std::string json) {
    scene_ = std::move(json);
    broadcast(scene_, false);
}

}  // namespace rtpm::server
