// The viewer port's plain HTTP side: the page's files (server/web/, embedded), nothing else.
#pragma once

#include <string>

#include "server/viewer/ws_endpoint.h"

namespace rtpm::server {

/// The answer to `method` `path` (without the query): GET or HEAD of an embedded file ("/" is
/// /index.html) with its type and a strict Content-Security-Policy, 404 for any other path, 405
/// for any other method. Never cached (a rebuilt binary serves new files). Pure: no state.
WsEndpoint::HttpReply serveWebAsset(const std::string& method, std::string path);

}  // namespace rtpm::server
