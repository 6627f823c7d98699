// The programs' shared command-line parser (app/option_parser.hpp): values land where declared,
// ranges and choices are enforced, and both message styles say what is wrong.
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "app/option_parser.hpp"

namespace gis::test {
namespace {

/// argv from words (argv[0] is the program).
struct Args {
  explicit Args(std::vector<std::string> words) : words_(std::move(words)) {
    pointers_.push_back(program_.data());
    for (std::string& w : words_) pointers_.push_back(w.data());
  }
  int argc() { return static_cast<int>(pointers_.size()); }
  char** argv() { return pointers_.data(); }

 private:
  std::string program_ = "prog";
  std::vector<std::string> words_;
  std::vector<char*> pointers_;
};

enum class Op { And, Or };

struct Options {
  std::string scene;
  int width = 10;
  double tolerance = 1.5;
  std::optional<double> exaggeration;
  bool open = false;
  bool help = false;
  Op op = Op::And;
  std::string positional;
};

app::OptionParser parserFor(Options& o, app::OptionParser::Style style) {
  app::OptionParser p(style);
  p.option("--scene", o.scene);
  p.option("--width", o.width, 1, 100);
  p.option("--tolerance", o.tolerance, 0.0, 10.0);
  p.option("--exaggeration", o.exaggeration, 0.001, 1000.0);
  p.flag("--open", o.open);
  p.help(o.help);
  p.choice<Op>("--op", o.op, {{"and", Op::And}, {"or", Op::Or}});
  return p;
}

TEST(OptionParser, ValuesLandWhereDeclared) {
  Options o;
  Args a({"--scene", "s.json", "--width", "64", "--tolerance", "0.25", "--open", "--exaggeration", "3", "--op", "or"});
  EXPECT_EQ(parserFor(o, app::OptionParser::Style::Explain).parse(a.argc(), a.argv()), "");
  EXPECT_EQ(o.scene, "s.json");
  EXPECT_EQ(o.width, 64);
  EXPECT_DOUBLE_EQ(o.tolerance, 0.25);
  EXPECT_TRUE(o.open);
  ASSERT_TRUE(o.exaggeration.has_value());
  EXPECT_DOUBLE_EQ(*o.exaggeration, 3.0);
  EXPECT_EQ(o.op, Op::Or);
  EXPECT_FALSE(o.help);
}

TEST(OptionParser, BadValuesAndUnknownFlagsAreNamed) {
  struct Case {
    std::vector<std::string> args;
    std::string explain;  ///< the message in Style::Explain (empty: accepted)
  };
  const std::vector<Case> cases{
      {{"--width", "0"}, "--width needs"},
      {{"--width", "12x"}, "--width needs"},
      {{"--width", "101"}, "--width needs"},
      {{"--tolerance", "nan"}, "--tolerance needs"},
      {{"--tolerance", "inf"}, "--tolerance needs"},
      {{"--op", "xor"}, "--op needs one of"},
      {{"--bogus", "1"}, "unknown argument '--bogus'"},
      {{"--scene"}, "--scene needs"},
      {{"stray"}, "unknown argument 'stray'"},
  };
  for (const Case& c : cases) {
    Options o;
    Args a(c.args);
    const std::string error = parserFor(o, app::OptionParser::Style::Explain).parse(a.argc(), a.argv());
    EXPECT_NE(error.find(c.explain), std::string::npos) << c.args.front() << ": '" << error << "'";
    EXPECT_EQ(o.width, 10) << "a bad value changes nothing";
  }
  Options o;
  Args bad({"--width", "0"}), missing({"--frames"}), unknown({"--bogus", "2"});
  EXPECT_EQ(parserFor(o, app::OptionParser::Style::BadArgument).parse(bad.argc(), bad.argv()),
            "bad argument --width 0");
  EXPECT_EQ(parserFor(o, app::OptionParser::Style::BadArgument).parse(missing.argc(), missing.argv()),
            "--frames needs a value");
  EXPECT_EQ(parserFor(o, app::OptionParser::Style::BadArgument).parse(unknown.argc(), unknown.argv()),
            "bad argument --bogus 2");
}

TEST(OptionParser, HelpStopsAndAPositionalArgumentIsTaken) {
  Options o;
  Args help({"--width", "5", "-h", "--bogus"});
  EXPECT_EQ(parserFor(o, app::OptionParser::Style::Explain).parse(help.argc(), help.argv()), "");
  EXPECT_TRUE(o.help);
  Options p;
  app::OptionParser parser = parserFor(p, app::OptionParser::Style::Explain);
  parser.positional(p.positional);
  Args file({"scene.json", "--open"});
  EXPECT_EQ(parser.parse(file.argc(), file.argv()), "");
  EXPECT_EQ(p.positional, "scene.json");
  EXPECT_TRUE(p.open);
}

}  // namespace
}  // namespace gis::test
