// Helpers of the multi-process tests: spawn and always reap children, temp dirs, bounded polls,
// and a tiny POSIX-socket fake server that speaks the protocol with timeouts.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "proto/messages.h"

extern char** environ;

namespace rtpm::test {

using Clock = std::chrono::steady_clock;

/// Path of a built executable: ${RTPM_BINARY_DIR}/<rel>.
inline std::string binaryPath(const std::string& rel) { return std::string(RTPM_BINARY_DIR) + "/" + rel; }

/// A fresh directory under the system temp dir, removed with everything in it on destruction.
class TempDir {
public:
    TempDir() {
        std::random_device rd;
        for (int i = 0; i < 100; ++i) {
            path_ = std::filesystem::temp_directory_path() /
                    ("rtpm-cluster-" + std::to_string(getpid()) + "-" + std::to_string(rd()));
            if (std::filesystem::create_directory(path_)) return;
        }
        throw std::runtime_error("cannot create a temp dir");
    }
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    std::string file(const std::string& name) const { return (path_ / name).string(); }

private:
    std::filesystem::path path_;
};

inline std::string readFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

/// How a child ended: exit code, or the signal that killed it.
struct ExitStatus {
    bool exited = false;
    int code = -1;    ///< valid when exited
    int signal = 0;   ///< valid when !exited
};

/// A child process (posix_spawn) with stdout and stderr sent to files. The destructor kills
/// (SIGKILL) and reaps a child still running, so no test leaves a process behind.
class Child {
public:
    /// Starts `argv[0]` (a path) with `argv`; `env` entries ("K=V") are added to this process's
    /// environment. Throws std::runtime_error if the spawn fails.
    Child(std::vector<std::string> argv, const std::string& logPrefix, const std::vector<std::string>& env = {})
        : outPath_(logPrefix + ".out"), errPath_(logPrefix + ".err") {
        posix_spawn_file_actions_t fa;
        posix_spawn_file_actions_init(&fa);
        posix_spawn_file_actions_addopen(&fa, 1, outPath_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        posix_spawn_file_actions_addopen(&fa, 2, errPath_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        std::vector<char*> args;
        for (std::string& a : argv) args.push_back(a.data());
        args.push_back(nullptr);
        std::vector<std::string> envStore;
        for (char** e = environ; *e; ++e) envStore.emplace_back(*e);
        for (const std::string& e : env) envStore.push_back(e);
        std::vector<char*> envp;
        for (std::string& e : envStore) envp.push_back(e.data());
        envp.push_back(nullptr);
        const int rc = posix_spawn(&pid_, args[0], &fa, nullptr, args.data(), envp.data());
        posix_spawn_file_actions_destroy(&fa);
        if (rc != 0) throw std::runtime_error("posix_spawn " + argv[0] + " failed: " + std::to_string(rc));
    }
    ~Child() {
        if (!status_) {
            kill(pid_, SIGKILL);
            int st = 0;
            waitpid(pid_, &st, 0);
        }
    }
    Child(const Child&) = delete;
    Child& operator=(const Child&) = delete;

    pid_t pid() const { return pid_; }
    /// The exit status once the child ended (non-blocking check).
    std::optional<ExitStatus> poll() {
        if (status_) return status_;
        int st = 0;
        if (waitpid(pid_, &st, WNOHANG) == pid_) status_ = decode(st);
        return status_;
    }
    /// Waits up to `timeout` for the child to end; nullopt if it is still running then.
    std::optional<ExitStatus> wait(std::chrono::milliseconds timeout) {
        const auto end = Clock::now() + timeout;
        while (!poll() && Clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(10));
        return status_;
    }
    void signal(int sig) {
        if (!status_) kill(pid_, sig);
    }
    std::string out() const { return readFile(outPath_); }
    std::string err() const { return readFile(errPath_); }
    /// stdout and stderr, for failure messages.
    std::string logs() const { return "--- stdout:\n" + out() + "--- stderr:\n" + err(); }

private:
    static ExitStatus decode(int st) {
        ExitStatus s;
        if (WIFEXITED(st)) {
            s.exited = true;
            s.code = WEXITSTATUS(st);
        } else if (WIFSIGNALED(st)) {
            s.signal = WTERMSIG(st);
        }
        return s;
    }
    pid_t pid_ = -1;
    std::string outPath_, errPath_;
    std::optional<ExitStatus> status_;
};

/// Polls `path` until it holds a port number (the server writes it atomically), at most
/// `timeout`; returns 0 if it never did or `server` ended first.
inline uint16_t waitForPortFile(const std::string& path, Child& server, std::chrono::milliseconds timeout) {
    const auto end = Clock::now() + timeout;
    while (Clock::now() < end) {
        std::ifstream in(path);
        unsigned port = 0;
        if (in >> port && port > 0 && port < 65536) return uint16_t(port);
        if (server.poll()) return 0;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return 0;
}

/// Polls `pred` every 10 ms for at most `timeout`; returns its last value.
template <class Pred>
bool waitUntil(Pred pred, std::chrono::milliseconds timeout) {
    const auto end = Clock::now() + timeout;
    while (!pred()) {
        if (Clock::now() >= end) return false;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return true;
}

/// A connected TCP socket with bounded-time send and receive (POSIX; tests only).
class Socket {
public:
    explicit Socket(int fd = -1) : fd_(fd) {}
    ~Socket() { close(); }
    Socket(Socket&& o) noexcept : fd_(o.fd_), splitter_(std::move(o.splitter_)) { o.fd_ = -1; }
    Socket& operator=(Socket&& o) noexcept {
        close();
        fd_ = o.fd_;
        o.fd_ = -1;
        splitter_ = std::move(o.splitter_);
        return *this;
    }
    /// Connects to 127.0.0.1:port; an invalid socket if that fails.
    static Socket connectLocal(uint16_t port) {
        int fd = ::socket(AF_INET, SOCK_STREAM, 0);
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_port = htons(port);
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
            ::close(fd);
            return Socket();
        }
        return Socket(fd);
    }
    bool valid() const { return fd_ >= 0; }
    void close() {
        if (fd_ >= 0) ::close(fd_);
        fd_ = -1;
    }
    /// Sends every byte; false if the peer is gone.
    bool sendAll(const std::vector<uint8_t>& b) {
        size_t off = 0;
        while (off < b.size()) {
            ssize_t n = ::send(fd_, b.data() + off, b.size() - off, MSG_NOSIGNAL);
            if (n <= 0) return false;
            off += size_t(n);
        }
        return true;
    }
    bool send(const proto::Message& m) { return sendAll(proto::encode(m)); }

    /// Result of waiting for a message.
    enum class Got { Message, Closed, Timeout, Garbage };
    /// Next whole message within `timeout`.
    Got receive(proto::Message& out, std::chrono::milliseconds timeout) {
        const auto end = Clock::now() + timeout;
        for (;;) {
            auto next = splitter_.next();
            if (!next.ok()) return Got::Garbage;
            if (next.value()) {
                out = std::move(*next.value());
                return Got::Message;
            }
            switch (waitReadable(end)) {
                case Got::Timeout: return Got::Timeout;
                case Got::Closed: return Got::Closed;
                default: break;
            }
            uint8_t buf[65536];
            ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
            if (n <= 0) return Got::Closed;
            splitter_.feed(std::span<const uint8_t>(buf, size_t(n)));
        }
    }
    /// Waits for the peer to close (EOF or reset), discarding anything it sends.
    bool waitClosed(std::chrono::milliseconds timeout) {
        const auto end = Clock::now() + timeout;
        for (;;) {
            Got g = waitReadable(end);
            if (g == Got::Timeout) return false;
            if (g == Got::Closed) return true;
            uint8_t buf[65536];
            if (::recv(fd_, buf, sizeof buf, 0) <= 0) return true;
        }
    }
    int fd() const { return fd_; }

private:
    Got waitReadable(Clock::time_point end) {
        for (;;) {
            const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count();
            if (left <= 0) return Got::Timeout;
            pollfd p{fd_, POLLIN, 0};
            int r = ::poll(&p, 1, int(left));
            if (r > 0) return (p.revents & (POLLIN | POLLHUP | POLLERR)) ? Got::Message : Got::Closed;
            if (r == 0) return Got::Timeout;
        }
    }
    int fd_ = -1;
    proto::FrameSplitter splitter_;
};

/// A listening socket on 127.0.0.1, port chosen by the kernel.
class Listener {
public:
    Listener() {
        fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
        int one = 1;
        setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(fd_, 8) != 0)
            throw std::runtime_error("cannot listen on 127.0.0.1");
        socklen_t len = sizeof a;
        getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
        port_ = ntohs(a.sin_port);
    }
    ~Listener() { ::close(fd_); }
    uint16_t port() const { return port_; }
    /// The next connection within `timeout`, or an invalid socket.
    Socket accept(std::chrono::milliseconds timeout) {
        pollfd p{fd_, POLLIN, 0};
        if (::poll(&p, 1, int(timeout.count())) <= 0) return Socket();
        return Socket(::accept(fd_, nullptr, nullptr));
    }

private:
    int fd_ = -1;
    uint16_t port_ = 0;
};

}  // namespace rtpm::test
