// The live station page of `imuqual serve --bus URL` (/live): the console's
// content (station, progress, processes, one row per unit and axis with its
// verdict, reason, state and live bias instability, the tally) and each
// unit's Allan curves as they grow, updated from /live/events (server-sent
// events, web/live_feed.h). Everything is drawn with DOM text nodes: no
// archived or bus string is ever parsed as HTML. The page keeps what it
// measured in window.imuqualLive (updates, latencies_ms: the time from a
// result's or acknowledgement's publication to its display) for the browser
// test and the benchmark.
#ifndef IMUQUAL_WEB_LIVE_PAGE_H_
#define IMUQUAL_WEB_LIVE_PAGE_H_

#include <string>

namespace imuqual::web {

// `bus_url`: the bus the server listens to; "" when it was started without
// --bus (the page then says how to start it). The page runs LivePageScript
// from /assets/live.js (no inline script: the server's policy forbids them).
std::string LivePageHtml(const std::string& bus_url);

// The page's script (JavaScript), served as /assets/live.js.
std::string LivePageScript();

}  // namespace imuqual::web

#endif  // IMUQUAL_WEB_LIVE_PAGE_H_
