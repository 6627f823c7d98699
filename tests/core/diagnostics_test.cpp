// Diagnostics grouped by kind for the log and the viewer (issue 40): one line per kind with its
// count and its first features, kinds in the order they came, numbers in a message set aside
// (shown where they differ as "N"), messages without a feature grouped only when identical.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/diagnostics.hpp"

namespace gis::test {
namespace {

Diagnostic featureError(const std::string& feature, const std::string& message, Severity severity = Severity::Error) {
  return {severity, "rivers.shp", "rivers", feature, message};
}

TEST(DiagnosticGroups, ManyOfOneKindAreOneLineWithTheCountAndTheFirstFeatures) {
  Diagnostics d;
  const std::string onePoint = "line: line has 1 distinct point(s); at least 2 needed";
  for (int i = 0; i < 16906; ++i) d.add(featureError(std::to_string(12 + 3 * i), onePoint));
  const std::vector<DiagnosticGroup> groups = groupDiagnostics(d);
  ASSERT_EQ(groups.size(), 1u);
  const DiagnosticGroup& g = groups[0];
  EXPECT_EQ(g.count, 16906u);
  EXPECT_EQ(g.features, 16906u);
  EXPECT_EQ(g.examples, (std::vector<std::string>{"12", "15", "18", "21", "24"}));
  EXPECT_EQ(g.message, onePoint);  // every number the same: shown as it is
  EXPECT_EQ(g.toString(),
            "error: rivers.shp: layer 'rivers': 16,906 features: line: line has 1 distinct point(s); at least 2 "
            "needed (features 12, 15, 18, 21, 24, …)");
  // As many examples as asked for.
  EXPECT_EQ(groupDiagnostics(d, 2)[0].examples, (std::vector<std::string>{"12", "15"}));
}

TEST(DiagnosticGroups, KindsKeepTheOrderTheyFirstCameInAndEachItsOwnCount) {
  Diagnostics d;
  d.add(featureError("7", "empty geometry"));
  d.add(featureError("8", "line: non-finite coordinate at vertex 3"));
  d.add(featureError("9", "empty geometry"));
  d.add(featureError("10", "line: non-finite coordinate at vertex 0"));
  d.add(featureError("11", "lies outside the terrain: nothing to draw", Severity::Warning));
  d.add(featureError("12", "empty geometry"));
  d.add(featureError("13", "empty geometry", Severity::Warning));            // another severity: another kind
  d.add({Severity::Error, "roads.shp", "rivers", "14", "empty geometry"});   // another file
  d.add({Severity::Error, "rivers.shp", "canals", "15", "empty geometry"});  // another layer
  const std::vector<DiagnosticGroup> groups = groupDiagnostics(d);
  ASSERT_EQ(groups.size(), 6u);
  EXPECT_EQ(groups[0].message, "empty geometry");
  EXPECT_EQ(groups[0].count, 3u);
  EXPECT_EQ(groups[0].examples, (std::vector<std::string>{"7", "9", "12"}));
  EXPECT_EQ(groups[0].toString(), "error: rivers.shp: layer 'rivers': 3 features: empty geometry (features 7, 9, 12)");
  // A number that differs within the kind is shown as N, the first message kept as it was.
  EXPECT_EQ(groups[1].message, "line: non-finite coordinate at vertex N");
  EXPECT_EQ(groups[1].count, 2u);
  EXPECT_EQ(groups[1].first.message, "line: non-finite coordinate at vertex 3");
  EXPECT_EQ(groups[1].examples, (std::vector<std::string>{"8", "10"}));
  // One of a kind is said as it always was.
  EXPECT_EQ(groups[2].count, 1u);
  EXPECT_EQ(groups[2].toString(),
            "warning: rivers.shp: layer 'rivers': feature 11: lies outside the terrain: nothing to draw");
  EXPECT_EQ(groups[3].severity, Severity::Warning);
  EXPECT_EQ(groups[4].file, "roads.shp");
  EXPECT_EQ(groups[5].layer, "canals");
  // Every message is in exactly one group.
  std::size_t total = 0;
  for (const DiagnosticGroup& g : groups) total += g.count;
  EXPECT_EQ(total, d.items().size());
}

TEST(DiagnosticGroups, NumbersAreSetAsideWithTheirSignsDecimalsAndExponents) {
  EXPECT_EQ(messageKind("vertex 12 (-34.88, 1e300) is outside the range"), "vertex N (N, N) is outside the range");
  EXPECT_EQ(messageKind("part 2 of 3: hole 1: ring has 2 distinct point(s)"),
            "part N of N: hole N: ring has N distinct point(s)");
  // A hyphen between a word and digits is no minus sign; the digits are still a number.
  EXPECT_EQ(messageKind("UTF-8 text, 2.5E-3 m"), "UTF-N text, N m");
  EXPECT_EQ(messageKind("no numbers here"), "no numbers here");
  // Only the numbers that differ become N.
  Diagnostics d;
  d.add(featureError("1", "part 1 of 3: line: line has 1 distinct point(s); at least 2 needed"));
  d.add(featureError("2", "part 3 of 3: line: line has 1 distinct point(s); at least 2 needed"));
  const std::vector<DiagnosticGroup> groups = groupDiagnostics(d);
  ASSERT_EQ(groups.size(), 1u);
  EXPECT_EQ(groups[0].message, "part N of 3: line: line has 1 distinct point(s); at least 2 needed");
}

TEST(DiagnosticGroups, OtherTextMakesAnotherKind) {
  Diagnostics d;
  d.add(featureError("1", "'width_m' = 'wide' is not a positive number of metres"));
  d.add(featureError("2", "'width_m' = 'narrow' is not a positive number of metres"));
  d.add(featureError("3", "'width_m' = '-4' is not a positive number of metres"));
  d.add(featureError("4", "'width_m' = '0' is not a positive number of metres"));
  const std::vector<DiagnosticGroup> groups = groupDiagnostics(d);
  ASSERT_EQ(groups.size(), 3u);
  EXPECT_EQ(groups[2].message, "'width_m' = 'N' is not a positive number of metres");
  EXPECT_EQ(groups[2].count, 2u);
}

TEST(DiagnosticGroups, SeveralMessagesOfOneFeatureAreCountedAsMessages) {
  Diagnostics d;
  d.add(featureError("5", "part 1 of 4: line: line has 1 distinct point(s); at least 2 needed; that part is left out",
                     Severity::Warning));
  d.add(featureError("5", "part 2 of 4: line: line has 1 distinct point(s); at least 2 needed; that part is left out",
                     Severity::Warning));
  d.add(featureError("6", "part 4 of 4: line: line has 1 distinct point(s); at least 2 needed; that part is left out",
                     Severity::Warning));
  const std::vector<DiagnosticGroup> groups = groupDiagnostics(d);
  ASSERT_EQ(groups.size(), 1u);
  EXPECT_EQ(groups[0].count, 3u);
  EXPECT_EQ(groups[0].features, 2u);
  EXPECT_EQ(groups[0].toString(),
            "warning: rivers.shp: layer 'rivers': 3 messages about 2 features: part N of 4: line: line has 1 distinct "
            "point(s); at least 2 needed; that part is left out (features 5, 6)");
}

TEST(DiagnosticGroups, MessagesWithoutAFeatureAreGroupedOnlyWhenTheSame) {
  Diagnostics d;
  // Their numbers say which layer, or how many: kept apart.
  d.add({Severity::Error, "s.json", "", "", "'layers[1].kind': missing (\"polygon\" or \"line\")"});
  d.add({Severity::Error, "s.json", "", "", "'layers[2].kind': missing (\"polygon\" or \"line\")"});
  d.add({Severity::Warning, "a.shp", "a", "", "GDAL: a repeated complaint"});
  d.add({Severity::Warning, "a.shp", "a", "", "GDAL: a repeated complaint"});
  const std::vector<DiagnosticGroup> groups = groupDiagnostics(d);
  ASSERT_EQ(groups.size(), 3u);
  EXPECT_EQ(groups[0].toString(), "error: s.json: 'layers[1].kind': missing (\"polygon\" or \"line\")");
  EXPECT_EQ(groups[1].count, 1u);
  EXPECT_EQ(groups[2].count, 2u);
  EXPECT_EQ(groups[2].features, 0u);
  EXPECT_EQ(groups[2].toString(), "warning: a.shp: layer 'a': GDAL: a repeated complaint (2 times)");
}

TEST(DiagnosticGroups, CountsHaveThousandsSeparators) {
  EXPECT_EQ(countText(0), "0");
  EXPECT_EQ(countText(999), "999");
  EXPECT_EQ(countText(1000), "1,000");
  EXPECT_EQ(countText(16906), "16,906");
  EXPECT_EQ(countText(1234567), "1,234,567");
}

TEST(DiagnosticGroups, NothingGivesNoGroup) { EXPECT_TRUE(groupDiagnostics(Diagnostics{}).empty()); }

}  // namespace
}  // namespace gis::test
