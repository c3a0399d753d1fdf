// The render worker's networking: connect with backoff, handshake, receive while rendering, reply.
#pragma once

#include <cstdint>
#include <string>

namespace rtpm::client {

/// Process exit codes of rtpm-client (also returned by Worker::run); deploy/MULTI-HOST.md §10.
inline constexpr int kExitOk = 0;             ///< the master said the run is complete (Bye{Normal})
inline constexpr int kExitStartup = 1;        ///< bad flags, no master reachable in time, internal error
inline constexpr int kExitUsage = 2;          ///< the command line cannot be used (as every rtpm program)
inline constexpr int kExitRejected = 5;       ///< refused: token, version (at once), capacity (once retries ran out)
inline constexpr int kExitServerGone = 3;     ///< the master stopped (Bye{Shutdown}), closed or reset the
                                              ///< connection, or fell silent past the idle timeout, and did
                                              ///< not take the client back within the rejoin timeout
inline constexpr int kExitProtocolError = 4;  ///< the master sent something unusable, or said Bye{ProtocolError}
inline constexpr int kExitEvicted = 7;        ///< evicted (Bye{Timeout}: late or frozen) and not taken back
                                              ///< within the rejoin timeout
// SIGINT / SIGTERM: the client says Bye{Shutdown} and exits with 128 + the signal number.

/// How to reach the server and what to tell it.
struct WorkerOptions {
    std::string host = "127.0.0.1";
    uint16_t port = 0;         ///< 0: read it from portFile
    std::string portFile;      ///< file holding the port as decimal text (rtpm-server --port-file)
    std::string token;         ///< shared secret: keys the Auth MAC, never sent
    std::string name;          ///< client name for the server's logs
    int threads = 0;           ///< TBB worker threads; 0 = every core
    double testSlowdown = 1.0; ///< tests only: work as if the machine were this many times slower
    double connectTimeoutSeconds = 30.0;  ///< total time for the first connection attempts
    /// After a session is lost for a reason that may pass (evicted, master closed the connection
    /// or fell silent, refused for capacity), keep trying to rejoin this long; 0 = exit at once.
    double rejoinTimeoutSeconds = 60.0;
    /// No byte from the master for this long means it is frozen or unreachable (it sends a
    /// Heartbeat every second): the client says Bye{Timeout} and tries to rejoin.
    double idleTimeoutSeconds = 10.0;
    bool verbose = false;      ///< one line per rendered frame on stdout
    bool tls = false;          ///< connect over TLS, verifying the server's certificate for `host`
    std::string tlsCa;         ///< PEM file of the CA(s) to trust; empty = the system's store
};

/// Parses "host:port", "[v6addr]:port", "host" or "[v6addr]" (port proto::kDefaultPort) into `host`
/// and `port`. Returns false (and leaves the outputs unchanged) if the host is empty or the port
/// is not a number in 1..65535.
bool parseHostPort(const std::string& text, std::string& host, uint16_t& port);

/// The render worker. run() connects (retrying with exponential backoff from 100 ms to 2 s until
/// connectTimeoutSeconds have passed; a port file that does not exist yet, a refused connection,
/// a connection closed before Welcome and a capacity refusal all count as failed attempts), sends
/// Hello, then runs the flow of PROTOCOL.md: one io_context on the calling thread receives and
/// writes; a render thread takes Settings, Scene, Edit and FrameBegin in arrival order and renders
/// frames in order while the next FrameBegin is being received. A session lost for a reason that
/// may pass (evicted, master gone or silent) is followed by a new one — fresh photon maps, the same
/// backoff — for up to rejoinTimeoutSeconds. Bad server data is answered with
/// Bye{ProtocolError, reason}. Prints what happened to stderr. Not reusable: call run() once.
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
