// PhotonRelay: a frame's shots reach the FrameBegin kSharedPhotonLag frames later, only within one
// epoch, scene version and M, only for a converging frame, and never beyond kMaxSharedPhotons.
#include <gtest/gtest.h>

#include "common/photon/set_photons.h"
#include "server/photon_relay.h"

namespace rtpm::server {
namespace {

std::vector<proto::PhotonRecord> photons(size_t n, float x = 0.0f) {
    return std::vector<proto::PhotonRecord>(n, proto::PhotonRecord{x, 0.0f, 0.0f, 1u, 2u});
}

TEST(PhotonRelay, ForwardsAFramesShotsTwoFramesLaterInAscendingSets) {
    static_assert(kSharedPhotonLag == 2);
    PhotonRelay relay;
    relay.began(0, 1, 1, 9);
    relay.record(0, 5, 1, photons(3, 5.0f));
    relay.record(0, 2, 2, photons(4, 2.0f));
    relay.record(0, 2, 1, photons(1, 9.0f));  // a second shot of the same set is ignored
    relay.record(0, 9, 1, photons(1));        // not a set of M = 3
    relay.record(7, 1, 1, photons(1));        // a frame that never began
    relay.began(1, 1, 1, 9);
    EXPECT_TRUE(relay.forwardFor(1, true).empty());  // nothing two frames before frame 1
    relay.began(2, 1, 1, 9);
    const auto shared = relay.forwardFor(2, true);
    ASSERT_EQ(shared.size(), 2u);
    EXPECT_EQ(shared[0].set, 2u);
    EXPECT_EQ(shared[0].batches, 2u);
    EXPECT_EQ(shared[0].photons, photons(4, 2.0f));
    EXPECT_EQ(shared[1].set, 5u);
    EXPECT_EQ(shared[1].photons.size(), 3u);
    EXPECT_TRUE(relay.forwardFor(2, false).empty());  // a moving frame bins nothing
}

TEST(PhotonRelay, NothingCrossesAnEpochASceneEditOrAChangeOfM) {
    for (int change = 0; change < 3; ++change) {
        PhotonRelay relay;
        relay.began(0, 1, 1, 9);
        relay.record(0, 0, 1, photons(2));
        relay.began(1, 1, 1, 9);
        relay.began(2, change == 0 ? 2 : 1, change == 1 ? 2 : 1, change == 2 ? 16 : 9);
        EXPECT_TRUE(relay.forwardFor(2, true).empty()) << "change " << change;
    }
}

TEST(PhotonRelay, OldFramesAreForgottenAndTheTotalIsBounded) {
    PhotonRelay relay;
    relay.began(0, 1, 1, 4);
    const size_t big = proto::kMaxSharedPhotons / 2 + 1;
    relay.record(0, 0, 1, photons(big));
    relay.record(0, 1, 1, photons(big));  // would exceed the total with set 0
    relay.record(0, 2, 1, photons(10));
    relay.began(1, 1, 1, 4);
    relay.began(2, 1, 1, 4);
    const auto shared = relay.forwardFor(2, true);
    ASSERT_EQ(shared.size(), 2u);
    EXPECT_EQ(shared[0].set, 0u);
    EXPECT_EQ(shared[1].set, 2u);
    relay.began(3, 1, 1, 4);
    relay.began(4, 1, 1, 4);
    EXPECT_TRUE(relay.forwardFor(2, true).empty());  // frame 0 was forgotten when frame 3 began
}

}  // namespace
}  // namespace rtpm::server
