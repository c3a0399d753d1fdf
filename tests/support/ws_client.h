// A minimal HTTP and WebSocket client over POSIX sockets with timeouts, for probing the
// viewer's port the way a hostile peer would (raw bytes, any source address on 127/8).
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>

namespace rtpm::test {

/// One TCP connection to 127.0.0.1:port from `source` (any 127.x.y.z: each is its own address
/// to the server's per-address budgets).
class RawHttp {
public:
    RawHttp() = default;
    RawHttp(uint16_t port, const char* source = "127.0.0.1") {
        fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
        sockaddr_in from{};
        from.sin_family = AF_INET;
        inet_pton(AF_INET, source, &from.sin_addr);
        sockaddr_in to{};
        to.sin_family = AF_INET;
        to.sin_port = htons(port);
        to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&from), sizeof from) != 0 ||
            ::connect(fd_, reinterpret_cast<sockaddr*>(&to), sizeof to) != 0)
            close();
    }
    ~RawHttp() { close(); }
    RawHttp(RawHttp&& o) noexcept : fd_(o.fd_), eof_(o.eof_), buf_(std::move(o.buf_)) { o.fd_ = -1; }
    RawHttp& operator=(RawHttp&& o) noexcept {
        close();
        fd_ = o.fd_;
        eof_ = o.eof_;
        buf_ = std::move(o.buf_);
        o.fd_ = -1;
        return *this;
    }
    bool valid() const { return fd_ >= 0; }
    void close() {
        if (fd_ >= 0) ::close(fd_);
        fd_ = -1;
    }

    bool sendRaw(const std::string& bytes) {
        size_t off = 0;
        while (off < bytes.size()) {
            const ssize_t n = ::send(fd_, bytes.data() + off, bytes.size() - off, MSG_NOSIGNAL);
            if (n <= 0) return false;
            off += size_t(n);
        }
        return true;
    }

    /// Sends a GET of `path` (a WebSocket upgrade when `upgrade`) with `extraHeaders` (each line
    /// ending in \r\n) and returns the response's status code, 0 if none came within `timeout`.
    int request(const std::string& path, bool upgrade, const std::string& extraHeaders,
                std::chrono::milliseconds timeout = std::chrono::milliseconds(3000),
                const std::string& host = "127.0.0.1") {
        std::string req = "GET " + path + " HTTP/1.1\r\nHost: " + host + "\r\n";
        if (upgrade)
            req += "Upgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                   "Sec-WebSocket-Version: 13\r\n";
        req += extraHeaders + "\r\n";
        if (!sendRaw(req)) return 0;
        const auto end = std::chrono::steady_clock::now() + timeout;
        size_t head;
        while ((head = buf_.find("\r\n\r\n")) == std::string::npos)
            if (!fill(end)) return 0;
        const std::string status = buf_.substr(0, head);
        buf_.erase(0, head + 4);
        if (status.size() < 12 || status.compare(0, 5, "HTTP/") != 0) return 0;
        return std::atoi(status.c_str() + 9);
    }

    /// Sends one masked (zero key) WebSocket text frame.
    bool sendText(const std::string& text) {
        std::string f(1, char(0x81));
        if (text.size() < 126) {
            f += char(0x80 | text.size());
        } else {
            f += char(0x80 | 126);
            f += char((text.size() >> 8) & 0xff);
            f += char(text.size() & 0xff);
        }
        f += std::string(4, '\0');  // masking key 0: the payload goes as is
        return sendRaw(f + text);
    }

    /// The next WebSocket text message (binary frames and control frames skipped), nullopt when
    /// the connection closed or `timeout` passed.
    std::optional<std::string> readText(std::chrono::milliseconds timeout) {
        const auto end = std::chrono::steady_clock::now() + timeout;
        for (;;) {
            while (buf_.size() < 2)
                if (!fill(end)) return std::nullopt;
            const unsigned op = uint8_t(buf_[0]) & 0x0f;
            uint64_t len = uint8_t(buf_[1]) & 0x7f;
            size_t at = 2;
            if (len >= 126) {
                const size_t n = len == 126 ? 2 : 8;
                while (buf_.size() < 2 + n)
                    if (!fill(end)) return std::nullopt;
                len = 0;
                for (size_t i = 0; i < n; ++i) len = (len << 8) | uint8_t(buf_[2 + i]);
                at += n;
            }
            while (buf_.size() < at + len)
                if (!fill(end)) return std::nullopt;
            std::string payload = buf_.substr(at, size_t(len));
            buf_.erase(0, at + size_t(len));
            if (op == 0x8) return std::nullopt;  // close
            if (op == 0x1) return payload;
        }
    }

    /// Whether a WebSocket binary message arrives within `timeout` (text messages are skipped).
    bool readBinary(std::chrono::milliseconds timeout) {
        const auto end = std::chrono::steady_clock::now() + timeout;
        for (;;) {
            while (buf_.size() < 2)
                if (!fill(end)) return false;
            const unsigned op = uint8_t(buf_[0]) & 0x0f;
            uint64_t len = uint8_t(buf_[1]) & 0x7f;
            size_t at = 2;
            if (len >= 126) {
                const size_t n = len == 126 ? 2 : 8;
                while (buf_.size() < 2 + n)
                    if (!fill(end)) return false;
                len = 0;
                for (size_t i = 0; i < n; ++i) len = (len << 8) | uint8_t(buf_[2 + i]);
                at += n;
            }
            while (buf_.size() < at + len)
                if (!fill(end)) return false;
            buf_.erase(0, at + size_t(len));
            if (op == 0x2) return true;
            if (op == 0x8) return false;
        }
    }

    /// Whether the server closed the connection within `timeout` (anything it sends is read).
    bool closedWithin(std::chrono::milliseconds timeout) {
        const auto end = std::chrono::steady_clock::now() + timeout;
        while (fill(end)) buf_.clear();
        return fd_ < 0 || eof_;
    }

private:
    // Reads what is there (waiting until `end`); false on timeout, close or error.
    bool fill(std::chrono::steady_clock::time_point end) {
        if (fd_ < 0 || eof_) return false;
        const auto left =
            std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now()).count();
        pollfd p{fd_, POLLIN, 0};
        if (::poll(&p, 1, int(std::max<long long>(0, left))) <= 0) return false;  // polled once at least
        char tmp[65536];
        const ssize_t n = ::recv(fd_, tmp, sizeof tmp, 0);
        if (n <= 0) {
            eof_ = true;
            return false;
        }
        buf_.append(tmp, size_t(n));
        return true;
    }

    int fd_ = -1;
    bool eof_ = false;
    std::string buf_;
};

}  // namespace rtpm::test
