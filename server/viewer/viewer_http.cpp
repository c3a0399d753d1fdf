// Serving the embedded viewer page.
#include "server/viewer/viewer_http.h"

#include "server/viewer/web_assets.h"

namespace rtpm::server {

WsEndpoint::HttpReply serveWebAsset(const std::string& method, std::string path) {
    WsEndpoint::HttpReply r;
    r.headers = {{"Cache-Control", "no-store"}, {"X-Content-Type-Options", "nosniff"}};
    if (method != "GET" && method != "HEAD") {
        r.status = 405;
        r.headers.emplace_back("Allow", "GET, HEAD");
        return r;
    }
    if (path == "/") path = "/index.html";
    for (const WebAsset& a : webAssets())
        if (a.path == path) {
            r.status = 200;
            r.headers.emplace_back("Content-Type", std::string(a.contentType));
            r.headers.emplace_back(
                "Content-Security-Policy",
                "default-src 'self'; img-src 'self' blob: data:; connect-src 'self'; "
                "style-src 'self'; script-src 'self'; frame-ancestors 'none'");
            if (method == "GET") r.body = std::string(a.body);
            return r;
        }
    r.status = 404;
    r.body = "not found\n";
    return r;
}

}  // namespace rtpm::server
