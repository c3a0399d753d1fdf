// A connection's write queue without sockets: the unread bound, the buffer in flight kept by
// dropUnsent, writes held while TLS is set up.
#include "proto/net/write_queue.h"

#include <gtest/gtest.h>

namespace rtpm::net {
namespace {

WriteQueue::Buffer bytes(size_t n) { return std::make_shared<const std::vector<uint8_t>>(n, uint8_t(7)); }

TEST(WriteQueue, MoreUnsentBytesThanTheBoundAreRefused) {
    WriteQueue q(100);
    EXPECT_TRUE(q.push(bytes(60)));
    EXPECT_TRUE(q.push(bytes(40)));
    EXPECT_EQ(q.bytes(), 100u);
    EXPECT_FALSE(q.push(bytes(1))) << "101 bytes unread: the peer is not reading";
    q.clear();
    EXPECT_TRUE(q.empty());
    EXPECT_EQ(q.bytes(), 0u);
}

TEST(WriteQueue, WrittenBuffersLeaveInOrder) {
    WriteQueue q(1000);
    q.push(bytes(10));
    q.push(bytes(20));
    EXPECT_EQ(q.front()->size(), 10u);
    q.popFront();
    EXPECT_EQ(q.front()->size(), 20u);
    EXPECT_EQ(q.bytes(), 20u);
}

TEST(WriteQueue, DropUnsentKeepsTheBufferBeingWritten) {
    WriteQueue q(1000);
    q.push(bytes(10));
    q.push(bytes(20));
    q.push(bytes(30));
    q.setWriting(true);
    q.dropUnsent();
    ASSERT_FALSE(q.empty());
    EXPECT_EQ(q.front()->size(), 10u) << "a message is never cut";
    EXPECT_EQ(q.bytes(), 10u);
    q.popFront();
    q.setWriting(false);
    q.push(bytes(5));
    q.dropUnsent();
    EXPECT_TRUE(q.empty()) << "nothing in flight: everything goes";
}

TEST(WriteQueue, HeldWritesAndTheCloseAfterTheQueueDrains) {
    WriteQueue q(1000);
    EXPECT_FALSE(q.held());
    q.hold();
    EXPECT_TRUE(q.held());
    q.release();
    EXPECT_FALSE(q.held());
    EXPECT_FALSE(q.closeWhenEmpty());
    q.setCloseWhenEmpty();
    EXPECT_TRUE(q.closeWhenEmpty());
}

}  // namespace
}  // namespace rtpm::net
