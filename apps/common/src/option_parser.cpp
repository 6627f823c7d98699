#include "app/option_parser.hpp"

#include "app/cli.hpp"

namespace gis::app {

void OptionParser::option(std::string name, std::string& target) {
  custom(std::move(name), [&target](std::string_view v) {
    target = std::string(v);
    return true;
  });
}

namespace {

template <class T>
std::string range(const char* what, T lo, T hi) {
  return std::string(what) + " in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
}

/// Sets a double or an optional<double> to a finite number in [lo, hi].
template <class Target>
OptionParser::Setter numberIn(Target& target, double lo, double hi) {
  return [&target, lo, hi](std::string_view v) {
    const std::optional<double> x = parseDouble(v);
    if (!x || *x < lo || *x > hi) return false;
    target = *x;
    return true;
  };
}

}  // namespace

void OptionParser::option(std::string name, int& target, int lo, int hi) {
  custom(
      std::move(name),
      [&target, lo, hi](std::string_view v) {
        const std::optional<int> n = parseInt(v);
        if (!n || *n < lo || *n > hi) return false;
        target = *n;
        return true;
      },
      range("an integer", lo, hi));
}

void OptionParser::option(std::string name, double& target, double lo, double hi) {
  custom(std::move(name), numberIn(target, lo, hi), range("a number", lo, hi));
}

void OptionParser::option(std::string name, std::optional<double>& target, double lo, double hi) {
  custom(std::move(name), numberIn(target, lo, hi), range("a number", lo, hi));
}

void OptionParser::flag(std::string name, bool& target) {
  add({std::move(name), Kind::Flag, [&target](std::string_view) { return target = true; }, {}, {}});
}

void OptionParser::help(bool& target) {
  for (const char* name : {"--help", "-h"}) {
    add({name, Kind::Help, [&target](std::string_view) { return target = true; }, {}, {}});
  }
}

void OptionParser::custom(std::string name, Setter set, std::string needs, Complaint complaint) {
  add({std::move(name), Kind::Value, std::move(set), std::move(needs), std::move(complaint)});
}

void OptionParser::positional(std::string& target) { positional_ = &target; }

void OptionParser::add(Option option) { options_.push_back(std::move(option)); }

void OptionParser::addChoice(std::string name, const std::vector<std::string>& names,
                             std::function<void(std::size_t)> pick) {
  std::string list;
  for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
  custom(
      std::move(name),
      [names, pick = std::move(pick)](std::string_view v) {
        for (std::size_t i = 0; i < names.size(); ++i) {
          if (names[i] == v) {
            pick(i);
            return true;
          }
        }
        return false;
      },
      "one of " + list);
}

const OptionParser::Option* OptionParser::find(std::string_view name) const {
  for (const Option& o : options_) {
    if (o.name == name) return &o;
  }
  return nullptr;
}

std::string OptionParser::badValue(const Option& option, std::string_view value) const {
  if (option.complaint) return option.complaint(value);
  if (style_ == Style::BadArgument) return "bad argument " + option.name + " " + std::string(value);
  return option.name + " needs " + option.needs;
}

std::string OptionParser::parse(int argc, char** argv) const {
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    // BadArgument style reads pairs: a flag without its value is reported before the flag is
    // looked at.
    if (style_ == Style::BadArgument && i + 1 >= argc) return std::string(a) + " needs a value";
    const Option* option = find(a);
    if (option == nullptr) {
      if (positional_ != nullptr && (a.empty() || a[0] != '-')) {
        *positional_ = std::string(a);
        continue;
      }
      if (style_ == Style::BadArgument) return "bad argument " + std::string(a) + " " + argv[i + 1];
      return "unknown argument '" + std::string(a) + "'";
    }
    if (option->kind == Kind::Help) {
      option->set({});
      return {};
    }
    if (option->kind == Kind::Flag) {
      option->set({});
      continue;
    }
    if (i + 1 >= argc) return option->name + " needs " + option->needs;
    const std::string_view value = argv[++i];
    if (!option->set(value)) return badValue(*option, value);
  }
  return {};
}

}  // namespace gis::app
