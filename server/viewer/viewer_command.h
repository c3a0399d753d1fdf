// Controls a browser viewer sends, parsed and validated without sockets.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <variant>

#include "server/script/script_edit.h"

namespace rtpm::server {

/// Which buffer a viewer shows.
enum class ViewerLayer : uint8_t { Final, Direct, Caustic, CausticUnfiltered };
const char* viewerLayerName(ViewerLayer layer);

/// First message of every viewer: the cluster or viewer token ("" for read-only viewing).
struct ViewerHello { std::string token; };
/// Tone mapping of this viewer's frames (viewer-local: changes no other viewer and no edit).
struct ViewerDisplay { ViewerLayer layer = ViewerLayer::Final; float exposureStops = 0.0f; };
/// The viewer drew frame `frame` and can take the next one (latest-frame-wins flow control).
struct ViewerAck { uint64_t frame = 0; };
/// A scene, camera or settings edit, through the same path as an --edit-script line
/// (`frame` is filled in by the master: the next frame it begins).
struct ViewerEdit { ScriptEdit edit; };
struct ViewerPause { bool paused = false; };
struct ViewerSnapshot {};
struct ViewerScriptRequest {};

using ViewerCommand = std::variant<ViewerHello, ViewerDisplay, ViewerAck, ViewerEdit, ViewerPause, ViewerSnapshot,
                                   ViewerScriptRequest>;

/// Largest control message accepted, in bytes.
inline constexpr size_t kMaxViewerMessageBytes = 4096;

/// Either a command or the reason the message was refused.
struct ViewerParse {
    std::variant<ViewerCommand, std::string> value;
    bool ok() const { return value.index() == 0; }
    const ViewerCommand& command() const { return std::get<0>(value); }
    const std::string& error() const { return std::get<1>(value); }
};

/// Parses one JSON control message. Grammar (every object has "type"; unknown keys, wrong types,
/// non-finite or out-of-range numbers and messages over kMaxViewerMessageBytes are refused with a
/// message naming the field):
///   {"type":"hello","token":s}
///   {"type":"display","layer":"final|direct|caustic|caustic_unfiltered","exposure":ev∈[-20,20]}
///   {"type":"ack","frame":n}
///   {"type":"camera","eye":[x,y,z],"target":[x,y,z],"yfov":r∈(0,π)}           (each optional)
///   {"type":"light","index":i,"position":[x,y,z],"intensity":[r,g,b]≥0}
///   {"type":"material","index":i,"color":[r,g,b]∈[0,1],"ior":[1,4],"absorption":[r,g,b]≥0,
///    "emission":[r,g,b]≥0}
///   {"type":"transform","index":i,"translate":[x,y,z]}   (instance i moved from its loaded pose;
///    how the viewer moves an emissive object, the area light of scenes without a punctual one)
///   {"type":"settings", <viewer key>: <value>, …}   (one key per live knob, with the limits and
///    choices of its row in common/core/knobs.h: M, F, k, P, rmax, tree, estimator)
///   {"type":"pause","paused":bool}   {"type":"snapshot"}   {"type":"script"}
/// Coordinates are bounded by |v| ≤ 1e6, intensities by 1e9, absorption by 1e6. Pure.
ViewerParse parseViewerCommand(std::string_view text);

}  // namespace rtpm::server
