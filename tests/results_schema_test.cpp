// docs/results.schema.json: a real run's rows validate, and the schema catches what a reader would trip on
// (a missing field, a wrong type, an unknown field, a fraction above 1, an unknown stage kind, a schema
// keyword the validator does not implement).
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/cli_support.h"
#include "tests/json_schema.h"

namespace fs = std::filesystem;

namespace {

const fs::path kSchema = fs::path(__FILE__).parent_path().parent_path() / "docs" / "results.schema.json";

nlohmann::json readJson(const fs::path& p) {
  std::ifstream f(p);
  return nlohmann::json::parse(std::string(std::istreambuf_iterator<char>(f), {}));
}

TEST(ResultsSchema, ARenderRunValidatesAndEveryKindOfMistakeIsCaught) {
  const fs::path out = fs::temp_directory_path() / ("coneshadow_schema_" + std::to_string(::getpid()));
  fs::remove_all(out);
  cs::test::CliRun r = cs::test::cli("render --methods cone,cubesm --width 16 --height 16 --frames 1 --quiet --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json rows = readJson(out / "results.json");
  fs::remove_all(out);
  const cs::test::JsonSchema schema = cs::test::JsonSchema::fromFile(kSchema);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_TRUE(schema.validate(rows).empty());

  auto broken = [&](auto&& edit) {
    nlohmann::json copy = rows;
    edit(copy[1]);
    return schema.validate(copy);
  };
  EXPECT_FALSE(broken([](nlohmann::json& row) { row.erase("error"); }).empty()) << "a missing field";
  EXPECT_FALSE(broken([](nlohmann::json& row) { row["total_ms"] = "fast"; }).empty()) << "a wrong type";
  EXPECT_FALSE(broken([](nlohmann::json& row) { row["surprise"] = 1; }).empty()) << "an unknown top-level field";
  EXPECT_FALSE(broken([](nlohmann::json& row) { row["error"]["misclassified_fraction"] = 1.5; }).empty()) << "a fraction above 1";
  EXPECT_FALSE(broken([](nlohmann::json& row) { row["stages"][0]["kind"] = "sometimes"; }).empty()) << "a stage kind";
  EXPECT_FALSE(broken([](nlohmann::json& row) { row["provenance"]["schema_version"] = 3; }).empty()) << "a schema version";
  EXPECT_FALSE(broken([](nlohmann::json& row) { row["provenance"]["light"] = {1, 2}; }).empty()) << "a light of two numbers";
  EXPECT_FALSE(broken([](nlohmann::json& row) { row["stats"].erase("setting"); }).empty()) << "a row without its setting";
  EXPECT_TRUE(broken([](nlohmann::json& row) { row["stats"]["my_counter"] = {{"any", "value"}}; }).empty())
      << "a method's own stats are free";

  // A keyword the validator does not implement is an error, not a silent pass.
  cs::test::JsonSchema unsupported(nlohmann::json{{"type", "array"}, {"uniqueItems", true}});
  EXPECT_THROW(unsupported.validate(rows), std::runtime_error);
}

}  // namespace
