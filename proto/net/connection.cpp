// One protocol connection: read loop through the frame splitter, single-flight write queue, timeouts.
#include "proto/net/connection.h"

namespace rtpm::net {

namespace {
constexpr uint64_t kHeaderBytesForDeadline = proto::kHeaderBytes;
constexpr size_t kReadChunk = 256 * 1024;
/// Before authentication only a Hello and an Auth may arrive (< 1 KiB): a flood of pending
/// connections must not cost kReadChunk each.
constexpr size_t kPreAuthReadChunk = 4 * 1024;
}

Connection::Connection(asio::ip::tcp::socket socket, ConnectionHandler& handler, size_t maxQueuedBytes)
    : socket_(std::move(socket)),
      handler_(handler),
      timer_(socket_.get_executor()),
      readDeadline_(socket_.get_executor()),
      writes_(maxQueuedBytes) {
    asio::error_code ec;
    auto ep = socket_.remote_endpoint(ec);
    peer_ = ec ? std::string("?") : ep.address().to_string() + ":" + std::to_string(ep.port());
    socket_.set_option(asio::ip::tcp::no_delay(true), ec);
    readBuf_.resize(kPreAuthReadChunk);
}

void Connection::useTls(asio::ssl::context& context, bool server, const std::string& verifyHost) {
    tls_ = std::make_unique<asio::ssl::stream<asio::ip::tcp::socket>>(std::move(socket_), context);
    tlsServer_ = server;
    writes_.hold();  // until the TLS handshake is done
    if (!server && !verifyHost.empty()) {
        tls_->set_verify_mode(asio::ssl::verify_peer);
        tls_->set_verify_callback(asio::ssl::host_name_verification(verifyHost));
        asio::error_code notAnAddress;
        asio::ip::make_address(verifyHost, notAnAddress);
        if (notAnAddress) SSL_set_tlsext_host_name(tls_->native_handle(), verifyHost.c_str());  // SNI names hosts only
    }
}

void Connection::start(std::chrono::milliseconds handshakeTimeout) {
    auto self = shared_from_this();
    if (handshakeTimeout.count() > 0) {
        timer_.expires_after(handshakeTimeout);
        timer_.async_wait([self](const asio::error_code& ec) {
            if (ec || self->finished_) return;
            self->handshakeTimedOut_ = true;
            self->close("handshake not completed within the handshake timeout");
        });
    }
    startReading();
}

void Connection::startReading() {
    if (!tls_) {
        readMore();
        return;
    }
    auto self = shared_from_this();
    tls_->async_handshake(tlsServer_ ? asio::ssl::stream_base::server : asio::ssl::stream_base::client,
                          [self](const asio::error_code& ec) {
                              if (self->finished_) return;
                              if (ec) {
                                  self->close("TLS handshake failed: " + ec.message());
                                  return;
                              }
                              self->writes_.release();
                              if (!self->writes_.writing()) self->writeNext();
                              self->readMore();
                          });
}

void Connection::markAuthenticated() {
    timer_.cancel();
    splitter_.allowAll();
    authenticated_ = true;
}

void Connection::setReadDeadline(std::chrono::milliseconds stall, uint64_t minBytesPerSecond) {
    readDeadline_.set(stall, minBytesPerSecond);
}

void Connection::updateReadDeadline() {
    if (!readDeadline_.enabled() || finished_ || closing_) return;
    if (splitter_.buffered() == 0) {  // between messages: no deadline
        readDeadline_.idle();
        return;
    }
    auto self = shared_from_this();
    readDeadline_.arm(kHeaderBytesForDeadline + splitter_.pendingPayloadBytes(), [self](ReadDeadline::TimePoint messageEnd) {
        if (self->finished_) return;
        // Bytes that arrived while this thread was busy are progress whose read has not run yet:
        // they re-arm the stall deadline, never the message's own bound.
        asio::error_code availableError;
        if (self->lowest().available(availableError) > 0 && !availableError &&
            std::chrono::steady_clock::now() < messageEnd) {
            self->updateReadDeadline();
            return;
        }
        const auto waited = std::chrono::duration_cast<std::chrono::milliseconds>(
            std::chrono::steady_clock::now() - self->readDeadline_.partialSince());
        self->close("stalled mid-message: " + std::to_string(self->splitter_.buffered()) + " of " +
                    std::to_string(kHeaderBytesForDeadline + self->splitter_.pendingPayloadBytes()) +
                    " bytes arrived in " + std::to_string(waited.count()) + " ms");
    });
}

void Connection::readMore() {
    if (authenticated_ && readBuf_.size() < kReadChunk) readBuf_.resize(kReadChunk);  // no read is in flight here
    auto self = shared_from_this();
    withStream([&](auto& stream) { stream.async_read_some(asio::buffer(readBuf_), [self](const asio::error_code& ec, size_t n) {
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
        self->updateReadDeadline();
        if (!self->finished_) self->readMore();
    }); });
}

void Connection::send(Buffer bytes) {
    if (finished_) return;
    if (!writes_.push(std::move(bytes))) {
        close("peer is not reading (" + std::to_string(writes_.bytes() >> 20) + " MiB queued)");
        return;
    }
    if (!writes_.writing() && !writes_.held()) writeNext();
}

void Connection::writeNext() {
    if (finished_) return;
    if (writes_.empty()) {
        writes_.setWriting(false);
        if (writes_.closeWhenEmpty()) finish("closed by this side");
        return;
    }
    writes_.setWriting(true);
    auto self = shared_from_this();
    withStream([&](auto& stream) { asio::async_write(stream, asio::buffer(*writes_.front()), [self](const asio::error_code& ec, size_t) {
        if (self->finished_) return;
        if (ec) {
            self->finish("write error: " + ec.message());
            return;
        }
        self->writes_.popFront();
        self->writeNext();
    }); });
}

void Connection::dropUnsent() { writes_.dropUnsent(); }

void Connection::closeAfterFlush(std::chrono::milliseconds grace) {
    if (finished_) return;
    closing_ = true;
    writes_.setCloseWhenEmpty();
    if (!writes_.writing() && writes_.empty()) {
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
    readDeadline_.cancel();
    // A TLS session ends without close_notify: the protocol's own Bye says the end was orderly.
    lowest().shutdown(asio::ip::tcp::socket::shutdown_both, ec);
    lowest().close(ec);
    writes_.clear();
    // Deliver onClosed from a fresh handler so callers of close() never see re-entrancy.
    auto self = shared_from_this();
    asio::post(timer_.get_executor(), [self, why] { self->handler_.onClosed(*self, why); });
}

bool Connection::peerSentBytes() {
    if (bytesReceived_ > 0 || splitter_.buffered() > 0) return true;
    asio::error_code ec;
    const size_t waiting = lowest().available(ec);
    return !ec && waiting > 0;
}

}  // namespace rtpm::net
