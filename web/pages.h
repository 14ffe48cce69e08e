// The pages and JSON documents of `imuqual serve`, built from the archive
// with the same code as the imuqual command's tables, plots and report
// (report/): pure apart from reading the archive, so every page can be
// tested without a server. Every text from the archive is escaped.
#ifndef IMUQUAL_WEB_PAGES_H_
#define IMUQUAL_WEB_PAGES_H_

#include <map>
#include <string>

#include "store/archive.h"

namespace imuqual::web {

struct Page {
  int status = 200;  // HTTP status: 200, or 404 for something the archive does not hold
  std::string content_type = "text/html; charset=utf-8";
  std::string body;
};

// A whole page in the site's frame (style, navigation); `body` is HTML.
std::string PageHtml(const std::string& title, const std::string& body);

// The site's navigation bar (lots, compare, yields, charts, station
// agreement, live, serial search): on every page, a served lot report too.
std::string SiteNavigation();

// GET `path` (already URL-decoded by the server, without the query) with
// `query` parameters. `archive_label` names the archive on the pages.
//   /                      the lots (yield, dates) and a search by serial
//   /lot/LOT               the lot's report (report/report.h), as `imuqual report` writes it
//                          (/lot?name=LOT, /run?id=ID, /api/lot?name=, /api/run?id= the
//                          same: links to a name "." or ".." take that form, since a
//                          browser resolves such a path segment away)
//   /unit/SERIAL           the unit's runs across lots
//   /unit?serial=S         the same (the search form)
//   /compare?a=LOT&b=LOT   two lots compared (`imuqual compare`: Welch, F, Fisher; Holm)
//   /run/RUN_ID            a run: identity, verdict and reasons, every measurement with its
//                          limits and outcome, its Allan plots and raw samples against time
//   /api/lots              JSON: the lots (the columns of `imuqual lots --format json`)
//   /api/lot/LOT           JSON: the lot's units per axis (`imuqual lot LOT --format json`)
//   /api/runs?lot=&serial= JSON: runs, newest first (`imuqual runs --format json`)
//   /api/run/RUN_ID        JSON: the run's measurements, one object each
//   /api/compare?a=&b=     JSON: the comparison (`imuqual compare --format json`)
// Anything else is a 404 page. An archive error is a 500 page naming it.
Page Route(store::Archive& archive, const std::string& archive_label, const std::string& path,
           const std::map<std::string, std::string>& query);

}  // namespace imuqual::web

#endif  // IMUQUAL_WEB_PAGES_H_
