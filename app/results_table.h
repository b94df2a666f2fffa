// `coneshadow results-table DIR...`: docs/RESULTS.md's results table, made from the results.json files that
// `coneshadow compare` wrote into each DIR, so the published numbers come from the tool itself.
#pragma once
#include <iosfwd>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace cs {

// Markdown: a device line, then one row per scene/view with each method setting's median ms and
// misclassified % outside the band (columns in first-seen setting order). `runs`: the parsed
// results.json arrays.
std::string resultsTable(const std::vector<nlohmann::json>& runs);

// Markdown, from the same rows (no figure of resultsTable repeated): per scene/view and size, the time
// of the first method's default setting (the registry's first: the cone path) over the reference's
// (Embree's build + rays) and over every other method's default setting (rows marked "defaults"; the
// 2048² cube map, rmsm@16M, ...) from the same run, and what each method's default setting cost the host
// a frame: submissions / host syncs / KiB read back / allocations / dispatches ("-" where a run lacks a
// peer or a method reports no counters).
std::string hostCostTable(const std::vector<nlohmann::json>& runs);

// Reads DIR/results.json of each folder (cs::Error naming the file when it cannot).
std::vector<nlohmann::json> readResults(const std::vector<std::string>& dirs);

// argv after "results-table": the folders; hostCost: hostCostTable instead of resultsTable. Prints the
// table to `out`; returns an exit code (usage errors: 2, unreadable results: cs::Error).
int runResultsTable(const std::vector<std::string>& dirs, std::ostream& out, bool hostCost = false);

}  // namespace cs
