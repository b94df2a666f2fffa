// `coneshadow results-table DIR...`: the README's results table, made from the results.json files that
// `coneshadow compare` wrote into each DIR, so the published numbers come from the tool itself.
#pragma once
#include <iosfwd>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace cs {

// Markdown: a device line, then one row per scene/view with each method setting's median ms and
// misclassified % outside the band (columns in first-seen setting order), and the cone path's time
// (its first setting: the default traversal memory) as a ratio of Embree's and of rmsm@16M's from the
// same run ("-" where a run lacks one). `runs`: the parsed results.json arrays.
std::string resultsTable(const std::vector<nlohmann::json>& runs);

// argv after "results-table": the folders. Prints the table to `out`; returns an exit code (usage
// errors: 2, unreadable results: cs::Error).
int runResultsTable(const std::vector<std::string>& dirs, std::ostream& out);

}  // namespace cs
