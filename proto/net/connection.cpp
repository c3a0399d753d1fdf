// One protocol connection: read loop through the frame splitter, single-flight write queue, timeouts.
#include "proto/net/connection.h"

namespace rtpm::net {

namespace {
constexpr size_t kReadChunk = 256 * 1024;
}

Connection::Connection(asio::ip::tcp::socket socket, ConnectionHandler& handler, size_t maxQueuedBytes)
    : socket_(std::move(socket)), handler_(handler), timer_(socket_.get_executor()), maxQueuedBytes_(maxQueuedBytes) {
    asio::error_code ec;
    auto ep = socket_.remote_endpoint(ec);
    peer_ = ec ? std::string("?") : ep.address().to_string() + ":" + std::to_string(ep.port());
    socket_.set_option(asio::ip::tcp::no_delay(true), ec);
    readBuf_.resize(kReadChunk);
}

void Connection::start(std::chrono::milliseconds handshakeTimeout) {
    auto self = shared_from_this();
    if (handshakeTimeout.count() <= 0) {
        readMore();
        return;
    }
    timer_.expires_after(handshakeTimeout);
    timer_.async_wait([self](const asio::error_code& ec) {
        if (ec || self->finished_) return;
        self->close("no valid Hello within the handshake timeout");
    });
    readMore();
}

void Connection::markAuthenticated() { timer_.cancel(); }

void Connection::readMore() {
    auto self = shared_from_this();
    socket_.async_read_some(asio::buffer(readBuf_), [self](const asio::error_code& ec, size_t n) {
        if (self->finished_) return;
        if (ec) {
            self->finish(ec == asio::error::eof ? "peer closed the connection" : "read error: " + ec.message());
            return;
        }
        if (self->closing_) {  // draining: ignore what a closing peer still sends
            self->readMore();
            return;
        }
        self->bytesReceived_ += n;
        self->splitter_.feed(std::span<const uint8_t>(self->readBuf_.data(), n));
        for (;;) {
            size_t before = self->splitter_.buffered();
            auto r = self->splitter_.next();
            if (!r.ok()) {
                self->closing_ = true;
                self->handler_.onBadBytes(*self, r.error());
                break;
            }
            if (!r->has_value()) break;
            size_t wire = before - self->splitter_.buffered();
            self->handler_.onMessage(*self, std::move(**r), wire);
            if (self->closing_ || self->finished_) break;
        }
        if (!self->finished_) self->readMore();
    });
}

void Connection::send(Buffer bytes) {
    if (finished_) return;
    queuedBytes_ += bytes->size();
    queue_.push_back(std::move(bytes));
    if (queuedBytes_ > maxQueuedBytes_) {
        close("peer is not reading (" + std::to_string(queuedBytes_ >> 20) + " MiB queued)");
        return;
    }
    if (!writing_) writeNext();
}

void Connection::writeNext() {
    if (finished_) return;
    if (queue_.empty()) {
        writing_ = false;
        if (flushing_) finish("closed by this side");
        return;
    }
    writing_ = true;
    auto self = shared_from_this();
    asio::async_write(socket_, asio::buffer(*queue_.front()), [self](const asio::error_code& ec, size_t) {
        if (self->finished_) return;
        if (ec) {
            self->finish("write error: " + ec.message());
            return;
        }
        self->queuedBytes_ -= self->queue_.front()->size();
        self->queue_.pop_front();
        self->writeNext();
    });
}

void Connection::dropUnsent() {
    while (queue_.size() > (writing_ ? 1u : 0u)) {
        queuedBytes_ -= queue_.back()->size();
        queue_.pop_back();
    }
}

void Connection::closeAfterFlush(std::chrono::milliseconds grace) {
    if (finished_) return;
    closing_ = true;
    flushing_ = true;
    if (!writing_ && queue_.empty()) {
        finish("closed by this side");
        return;
    }
    auto self = shared_from_this();
    timer_.expires_after(grace);
    timer_.async_wait([self](const asio::error_code& ec) {
        if (ec || self->finished_) return;
        self->finish("closed by this side (peer did not read its last messages)");
    });
}

void Connection::close(const std::string& why) {
    closing_ = true;
    finish(why);
}

void Connection::finish(const std::string& why) {
    if (finished_) return;
    finished_ = true;
    closing_ = true;
    asio::error_code ec;
    timer_.cancel();
    socket_.shutdown(asio::ip::tcp::socket::shutdown_both, ec);
    socket_.close(ec);
    queue_.clear();
    queuedBytes_ = 0;
    // Deliver onClosed from a fresh handler so callers of close() never see re-entrancy.
    auto self = shared_from_this();
    asio::post(socket_.get_executor(), [self, why] { self->handler_.onClosed(*self, why); });
}

}  // namespace rtpm::net
