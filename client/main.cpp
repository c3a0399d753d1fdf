// rtpm-client entry point: parses flags and runs one Worker session against the server.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <unistd.h>

#include "client/worker.h"
#include "common/cmd/command_line.h"
#include "common/core/console.h"
#include "proto/messages.h"

int main(int argc, char** argv) {
    rtpm::lineBufferConsole();
    using namespace rtpm::client;
    WorkerOptions o;
    std::string server;
    CLI::App app{"rtpm-client: render worker of the rtpm cluster. Connects to rtpm-server, renders the "
                 "interleaving sets it is given on every core and streams their pixels back.",
                 "rtpm-client"};
    rtpm::addStandardFlags(app, rtpm::proto::kProtocolVersion,
                     {{kExitOk, "the master said the run is complete"},
                      {kExitStartup, "start-up failure: no master reachable within --connect-timeout, internal error"},
                      {kExitServerGone, "the master stopped, closed the connection or fell silent, and did not take "
                                        "the client back within --rejoin-timeout"},
                      {kExitProtocolError, "the master sent something unusable (protocol error)"},
                      {kExitRejected, "refused by the master: token or version at once, capacity once the "
                                      "connect window ran out"},
                      {kExitEvicted, "evicted, and not taken back within --rejoin-timeout"},
                      {130, "stopped by SIGINT (128 + N for signal N; SIGTERM 143), after saying Bye"}},
                     {{"RTPM_TOKEN=<the master's token> rtpm-client --server 10.0.0.1",
                       "render on every core for the master at 10.0.0.1, port 7411"},
                      {"rtpm-client --port-file /tmp/rtpm.port --threads 2",
                       "a master on this machine started with --port 0 --port-file /tmp/rtpm.port, on 2 threads"}});
    auto* serverOpt = app.add_option("--server", server,
                                     "server address HOST:PORT ([v6]:PORT for IPv6); HOST alone uses port " +
                                         std::to_string(rtpm::proto::kDefaultPort));
    auto* portFileOpt = app.add_option("--port-file", o.portFile,
                                       "read the port from this file (rtpm-server --port-file); host from --host");
    app.add_option("--host", o.host, "server host when --port-file gives the port")->capture_default_str();
    app.add_option("--token", o.token, "shared secret (default: environment variable RTPM_TOKEN)");
    app.add_option("--name", o.name, "client name shown in the server's logs (default: HOST/PID)");
    app.add_option("--threads", o.threads, "render threads (0 = all cores)")
        ->capture_default_str()
        ->check(CLI::Range(0, 4096));
    app.add_option("--connect-timeout", o.connectTimeoutSeconds,
                   "seconds to keep retrying the connection (backoff 100 ms to 2 s; a port file not written yet is read again every 2 ms for the first 0.5 s)")
        ->capture_default_str()
        ->check(CLI::NonNegativeNumber);
    app.add_option("--rejoin-timeout", o.rejoinTimeoutSeconds,
                   "after being evicted, or losing a master that closed the connection or fell silent, keep "
                   "trying to rejoin this many seconds (same backoff; 0 = exit at once)")
        ->capture_default_str()
        ->check(CLI::NonNegativeNumber);
    app.add_option("--idle-timeout", o.idleTimeoutSeconds,
                   "seconds without any byte from the master (it sends a heartbeat every second) after which it "
                   "is taken as frozen or unreachable: Bye(timeout), then rejoin; 0 = never")
        ->capture_default_str()
        ->check(CLI::NonNegativeNumber);
    app.add_flag("--verbose,-v", o.verbose, "print one line per rendered frame");
    // Tests of the master's load balance where no CPU quota can be set: each frame takes this many
    // times its work (the rest asleep, reported as eye-pass time), as on a slower machine.
    app.add_option("--slowdown-for-tests", o.testSlowdown)->check(CLI::Range(1.0, 100.0))->group("");
    app.add_flag("--tls", o.tls, "connect over TLS and verify the server's certificate for the host name");
    app.add_option("--tls-ca", o.tlsCa, "PEM file of the CA to trust with --tls (default: the system's)");
    serverOpt->excludes(portFileOpt);
    if (auto code = rtpm::parseCommandLine(app, argc, argv)) return *code;
    if (o.name.empty()) {
        char hostName[256] = {};
        if (gethostname(hostName, sizeof hostName - 1) == 0) o.name = hostName;
        o.name += "/" + std::to_string(getpid());
    }
    if (serverOpt->count() == 0 && portFileOpt->count() == 0)
        return rtpm::reportUsageError("rtpm-client", rtpm::UsageError("give --server HOST[:PORT] or --port-file FILE"));
    if (serverOpt->count() && !parseHostPort(server, o.host, o.port))
        return rtpm::reportUsageError(
            "rtpm-client", rtpm::UsageError("--server \"" + server + "\" is not HOST[:PORT] with a port in 1..65535"));
    if (o.idleTimeoutSeconds > 0 && o.idleTimeoutSeconds < 2.0)
        return rtpm::reportUsageError("rtpm-client",
                                      rtpm::UsageError("--idle-timeout must be 0 (never) or >= 2 s: the master's "
                                                       "heartbeat comes every second"));
    if (o.token.empty())
        if (const char* env = std::getenv("RTPM_TOKEN")) o.token = env;
    if (o.token.empty())
        std::fprintf(stderr, "rtpm-client: warning: no token (--token or RTPM_TOKEN); only a server started "
                             "with --insecure-no-token accepts this client\n");
    if (o.token.size() > rtpm::proto::kMaxTokenBytes)
        return rtpm::reportUsageError("rtpm-client", rtpm::UsageError("the token is longer than " +
                                                                      std::to_string(rtpm::proto::kMaxTokenBytes) +
                                                                      " bytes"));
    if (o.name.size() > rtpm::proto::kMaxNameBytes) o.name.resize(rtpm::proto::kMaxNameBytes);
    return Worker(o).run();
}
