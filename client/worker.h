// The render worker's networking: connect with backoff, handshake, receive while rendering, reply.
#pragma once

#include <cstdint>
#include <string>

namespace rtpm::client {

/// Process exit codes of rtpm-client (also returned by Worker::run).
inline constexpr int kExitOk = 0;             ///< the server said Bye{Normal or Shutdown}
inline constexpr int kExitStartup = 1;        ///< bad flags, no server reachable in time, internal error
inline constexpr int kExitRejected = 2;       ///< the server refused the handshake (token, version, full)
inline constexpr int kExitServerGone = 3;     ///< the server closed or reset the connection
inline constexpr int kExitProtocolError = 4;  ///< the server sent something unusable, or said Bye{error}
// SIGINT / SIGTERM: the client says Bye{Shutdown} and exits with 128 + the signal number.

/// How to reach the server and what to tell it.
struct WorkerOptions {
    std::string host = "127.0.0.1";
    uint16_t port = 0;         ///< 0: read it from portFile
    std::string portFile;      ///< file holding the port as decimal text (rtpm-server --port-file)
    std::string token;         ///< shared secret: keys the Auth MAC, never sent
    std::string name;          ///< client name for the server's logs
    int threads = 0;           ///< TBB worker threads; 0 = every core
    double connectTimeoutSeconds = 30.0;  ///< total time for connection attempts
    bool verbose = false;      ///< one line per rendered frame on stdout
    bool tls = false;          ///< connect over TLS, verifying the server's certificate for `host`
    std::string tlsCa;         ///< PEM file of the CA(s) to trust; empty = the system's store
};

/// Parses "host:port", "[v6addr]:port" into `host` and `port`. Returns false (and leaves the
/// outputs unchanged) if the port is missing, not a number or outside 1..65535.
bool parseHostPort(const std::string& text, std::string& host, uint16_t& port);

/// One client session. run() connects (retrying with exponential backoff from 100 ms to 2 s
/// until connectTimeoutSeconds have passed; a port file that does not exist yet counts as a
/// failed attempt), sends Hello, then runs the flow of PROTOCOL.md: one io_context on the calling
/// thread receives and writes; a render thread takes Settings, Scene, Edit and FrameBegin in
/// arrival order and renders frames in order while the next FrameBegin is being received.
/// Bad server data is answered with Bye{ProtocolError, reason}. Prints what happened to stderr.
/// Not reusable: call run() once.
class Worker {
public:
    explicit Worker(WorkerOptions options);
    ~Worker();
    /// Returns one of the kExit* codes. Never throws.
    int run();

private:
    struct Impl;
    WorkerOptions options_;
};

}  // namespace rtpm::client
