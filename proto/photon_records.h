// The photon records of a shot on the wire (FrameData.shot, FrameBegin.shared; proto/PROTOCOL.md):
// a count, then x, y, z, power, incoming per photon, 4 bytes each, little-endian.
#pragma once

#include <cstddef>
#include <vector>

#include "proto/messages.h"
#include "proto/wire.h"

namespace rtpm::proto {

/// Appends the count and the records.
void putPhotons(Writer& w, const std::vector<PhotonRecord>& photons);
/// Reads at most `maxCount` records with finite positions (a non-finite one fails the reader,
/// naming `field`). Returns r.ok().
bool getPhotons(Reader& r, std::vector<PhotonRecord>& out, size_t maxCount, const char* field);

}  // namespace rtpm::proto
