#pragma once
// The programs' command lines (`--flag value`), declared once per option instead of parsed by hand
// in each program: the option, where its value goes, what it accepts and what to say otherwise.
#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace gis::app {

class OptionParser {
 public:
  /// Takes the option's value; false when the value is not acceptable.
  using Setter = std::function<bool(std::string_view value)>;
  /// The whole error message for an unacceptable value.
  using Complaint = std::function<std::string(std::string_view value)>;

  /// How a program words a bad command line (each keeps what its users and tests know).
  enum class Style {
    /// "--width needs an integer in [1, 16384]", "unknown argument '--x'"; flags take no value.
    Explain,
    /// Every argument is a flag and its value: "--frames needs a value" when the value is
    /// missing, else "bad argument --frames 2" for a bad value or an unknown flag.
    BadArgument,
  };

  explicit OptionParser(Style style = Style::Explain) : style_(style) {}

  void option(std::string name, std::string& target);
  /// An integer in [lo, hi].
  void option(std::string name, int& target, int lo, int hi);
  /// A finite number in [lo, hi].
  void option(std::string name, double& target, double lo, double hi);
  void option(std::string name, std::optional<double>& target, double lo, double hi);
  /// One of the named values; Explain style says "needs one of a, b, c".
  template <class T, class Target>
  void choice(std::string name, Target& target, std::vector<std::pair<std::string, T>> choices);
  /// No value: present or not.
  void flag(std::string name, bool& target);
  /// --help and -h: set `target` and stop parsing, whatever follows.
  void help(bool& target);
  /// Anything else. `needs` says what the value must be ("a file"); `complaint`, if given, is
  /// the message for a bad value instead of the style's.
  void custom(std::string name, Setter set, std::string needs = "a value", Complaint complaint = {});
  /// An argument that is not a flag (does not start with '-') goes here; without it, such an
  /// argument is an error.
  void positional(std::string& target);

  /// Sets the options from argv[1..argc); an error message, or an empty string.
  [[nodiscard]] std::string parse(int argc, char** argv) const;

 private:
  enum class Kind { Value, Flag, Help };
  struct Option {
    std::string name;
    Kind kind = Kind::Value;
    Setter set;         ///< Value: takes the value; Flag and Help: called with ""
    std::string needs;  ///< Value: what the value must be, for "--name needs …"
    Complaint complaint;
  };

  void add(Option option);
  void addChoice(std::string name, const std::vector<std::string>& names, std::function<void(std::size_t)> pick);
  [[nodiscard]] const Option* find(std::string_view name) const;
  [[nodiscard]] std::string badValue(const Option& option, std::string_view value) const;

  Style style_;
  std::vector<Option> options_;
  std::string* positional_ = nullptr;
};

template <class T, class Target>
void OptionParser::choice(std::string name, Target& target, std::vector<std::pair<std::string, T>> choices) {
  std::vector<std::string> names;
  for (const auto& c : choices) names.push_back(c.first);
  addChoice(std::move(name), names,
            [&target, choices = std::move(choices)](std::size_t i) { target = choices[i].second; });
}

}  // namespace gis::app
