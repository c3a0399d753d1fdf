// Photon records on the wire: on a little-endian host the wire's layout is PhotonRecord's own, so
// a shot (up to 2^18 photons, the bulk of a frame's bytes) is one copy each way.
#include "proto/photon_records.h"

#include <bit>
#include <cmath>
#include <cstring>
#include <span>
#include <string>

namespace rtpm::proto {
namespace {

constexpr size_t kPhotonWireBytes = 20;
constexpr bool kPhotonRecordIsWire = std::endian::native == std::endian::little &&
                                     sizeof(PhotonRecord) == kPhotonWireBytes && offsetof(PhotonRecord, y) == 4 &&
                                     offsetof(PhotonRecord, z) == 8 && offsetof(PhotonRecord, power) == 12 &&
                                     offsetof(PhotonRecord, incoming) == 16;

}  // namespace

void putPhotons(Writer& w, const std::vector<PhotonRecord>& photons) {
    w.u32(static_cast<uint32_t>(photons.size()));
    if constexpr (kPhotonRecordIsWire) {
        w.raw(std::span(reinterpret_cast<const uint8_t*>(photons.data()), photons.size() * kPhotonWireBytes));
        return;
    }
    for (const PhotonRecord& p : photons) {
        for (float v : {p.x, p.y, p.z}) w.f32(v);
        w.u32(p.power);
        w.u32(p.incoming);
    }
}

bool getPhotons(Reader& r, std::vector<PhotonRecord>& out, size_t maxCount, const char* field) {
    uint32_t n = 0;
    if (!r.count(n, maxCount, kPhotonWireBytes, field)) return false;
    out.resize(n);
    std::span<const uint8_t> bytes;
    if (kPhotonRecordIsWire && n > 0 && r.view(bytes, size_t(n) * kPhotonWireBytes, field))
        std::memcpy(out.data(), bytes.data(), bytes.size());
    for (PhotonRecord& p : out) {
        if (kPhotonRecordIsWire) {
            if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
                return r.fail(ErrorCode::NonFinite, std::string(field) + " is not finite");
            continue;
        }
        if (!r.f32Finite(p.x, field) || !r.f32Finite(p.y, field) || !r.f32Finite(p.z, field)) return false;
        r.u32(p.power);
        r.u32(p.incoming);
    }
    return r.ok();
}

}  // namespace rtpm::proto
