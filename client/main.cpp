// rtpm-client entry point: parses flags and runs one Worker session against the server.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <unistd.h>

#include "client/worker.h"
#include "common/core/console.h"
#include "proto/messages.h"

int main(int argc, char** argv) {
    rtpm::lineBufferConsole();
    using namespace rtpm::client;
    WorkerOptions o;
    std::string server;
    char hostName[256] = {};
    if (gethostname(hostName, sizeof hostName - 1) == 0) o.name = hostName;
    o.name += "/" + std::to_string(getpid());

    CLI::App app{"rtpm-client: render worker of the rtpm cluster. Connects to rtpm-server, renders the "
                 "interleaving sets it is given on every core and streams their pixels back.\n"
                 "Exit codes: 0 the master said the run is complete, 1 startup/connect failure, 2 refused by "
                 "the master, 3 the master stopped, closed the connection or fell silent (and did not take the "
                 "client back within --rejoin-timeout), 4 protocol error, 7 evicted (and not taken back within "
                 "--rejoin-timeout), 128+N stopped by signal N."};
    auto* serverOpt = app.add_option("--server", server, "server address host:port ([v6]:port for IPv6)");
    auto* portFileOpt = app.add_option("--port-file", o.portFile,
                                       "read the port from this file (rtpm-server --port-file); host from --host");
    app.add_option("--host", o.host, "server host when --port-file gives the port")->capture_default_str();
    app.add_option("--token", o.token, "shared secret (default: environment variable RTPM_TOKEN)");
    app.add_option("--name", o.name, "client name shown in the server's logs")->capture_default_str();
    app.add_option("--threads", o.threads, "render threads (0 = all cores)")->capture_default_str()->check(
        CLI::NonNegativeNumber);
    app.add_option("--connect-timeout", o.connectTimeoutSeconds,
                   "seconds to keep retrying the connection (backoff 100 ms to 2 s)")
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
    app.add_flag("--tls", o.tls, "connect over TLS and verify the server's certificate for the host name");
    app.add_option("--tls-ca", o.tlsCa, "PEM file of the CA to trust with --tls (default: the system's)");
    serverOpt->excludes(portFileOpt);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    if (serverOpt->count() == 0 && portFileOpt->count() == 0) {
        std::fprintf(stderr, "rtpm-client: give --server host:port or --port-file FILE\n");
        return kExitStartup;
    }
    if (serverOpt->count() && !parseHostPort(server, o.host, o.port)) {
        std::fprintf(stderr, "rtpm-client: --server \"%s\" is not host:port with a port in 1..65535\n",
                     server.c_str());
        return kExitStartup;
    }
    if (o.idleTimeoutSeconds > 0 && o.idleTimeoutSeconds < 2.0) {
        std::fprintf(stderr, "rtpm-client: --idle-timeout must be 0 (never) or >= 2 s: the master's heartbeat "
                             "comes every second\n");
        return kExitStartup;
    }
    if (o.token.empty())
        if (const char* env = std::getenv("RTPM_TOKEN")) o.token = env;
    if (o.token.empty())
        std::fprintf(stderr, "rtpm-client: warning: no token (--token or RTPM_TOKEN); only a server started "
                             "with --insecure-no-token accepts this client\n");
    if (o.token.size() > rtpm::proto::kMaxTokenBytes) {
        std::fprintf(stderr, "rtpm-client: the token is longer than %zu bytes\n", rtpm::proto::kMaxTokenBytes);
        return kExitStartup;
    }
    if (o.name.size() > rtpm::proto::kMaxNameBytes) o.name.resize(rtpm::proto::kMaxNameBytes);
    return Worker(o).run();
}
