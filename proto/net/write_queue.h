// A connection's outgoing buffers: one write in flight (Asio's rule), a bound on what may pile up
// unread, writes held back while TLS is set up, and the close that waits for the queue to drain. Pure: the connection does the writes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <vector>

namespace rtpm::net {

/// Not thread-safe (the connection's I/O thread).
class WriteQueue {
public:
    using Buffer = std::shared_ptr<const std::vector<uint8_t>>;

    /// `maxBytes`: unsent bytes beyond this mean the peer is not reading.
    explicit WriteQueue(size_t maxBytes) : maxBytes_(maxBytes) {}

    /// Queues `bytes`; false when the unsent bytes now exceed the bound (the caller closes).
    bool push(Buffer bytes) {
        bytes_ += bytes->size();
        queue_.push_back(std::move(bytes));
        return bytes_ <= maxBytes_;
    }
    bool empty() const { return queue_.empty(); }
    /// Unsent bytes, the buffer being written included.
    size_t bytes() const { return bytes_; }
    /// The buffer to write next (or being written). Precondition: !empty().
    const Buffer& front() const { return queue_.front(); }
    /// The front buffer was written.
    void popFront() {
        bytes_ -= queue_.front()->size();
        queue_.pop_front();
    }
    /// Drops every buffer except the one being written (a message is never cut).
    void dropUnsent() {
        while (queue_.size() > (writing_ ? 1u : 0u)) {
            bytes_ -= queue_.back()->size();
            queue_.pop_back();
        }
    }
    /// The connection closed: nothing more is sent.
    void clear() {
        queue_.clear();
        bytes_ = 0;
    }

    /// A write is in flight.
    bool writing() const { return writing_; }
    void setWriting(bool writing) { writing_ = writing; }
    /// Writes wait while held (the TLS handshake runs); a buffer pushed meanwhile is written once
    /// released.
    bool held() const { return held_; }
    void hold() { held_ = true; }
    void release() { held_ = false; }
    /// The connection closes once the queue is empty (closeAfterFlush).
    bool closeWhenEmpty() const { return closeWhenEmpty_; }
    void setCloseWhenEmpty() { closeWhenEmpty_ = true; }

private:
    std::deque<Buffer> queue_;
    size_t bytes_ = 0;
    size_t maxBytes_;
    bool writing_ = false;
    bool held_ = false;
    bool closeWhenEmpty_ = false;
};

}  // namespace rtpm::net
