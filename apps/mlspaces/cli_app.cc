// The CLI's shared set-up and error mapping (main.cc, and python/src/index.cc for the
// Python modules that run index-assets / index-grasps): the help formatter, the misspelled-flag
// hint, the exception -> exit-code mapping with escaped error lines, Warn, the shared flag
// checks (whole numbers, finite numbers, --seed).
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "commands.h"
#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/strings.h"
#include "mlspaces/core/yaml_archive.h"

namespace mlspaces::cli {

void Warn(const std::string& text) {
  std::fprintf(stderr, "mlspaces: warning: %s\n", Printable(text).c_str());
}

CLI::Validator WholeNumberIn(long long minimum, long long maximum) {
  // At most 18 digits and no sign: std::stoll cannot overflow.
  return CLI::Validator(
      [minimum, maximum](std::string& value) -> std::string {
        const bool digits = !value.empty() && value.size() <= 18 &&
                            value.find_first_not_of("0123456789") == std::string::npos;
        if (digits && std::stoll(value) >= minimum && std::stoll(value) <= maximum) return {};
        const std::string range =
            maximum == std::numeric_limits<long long>::max()
                ? ">= " + std::to_string(minimum)
                : "in [" + std::to_string(minimum) + ", " + std::to_string(maximum) + "]";
        return "expected a whole number " + range + ", got '" + value + "'";
      },
      "");  // no description: the help shows the option's type name alone (`--episodes N`)
}

CLI::Validator PositiveInteger() { return WholeNumberIn(1, std::numeric_limits<long long>::max()); }

CLI::Validator NonNegativeInteger() {
  return WholeNumberIn(0, std::numeric_limits<long long>::max());
}

namespace {

// A finite number (from_chars' syntax: no sign '+', hex or blanks) that `fits`; otherwise
// "expected <what>, got '<value>'". `description` shows in --help.
template <typename Fits>
CLI::Validator Number(Fits fits, const std::string& what, const std::string& description = "") {
  return CLI::Validator(
      [fits, what](std::string& value) -> std::string {
        double number = 0;
        const auto [ptr, ec] = std::from_chars(value.data(), value.data() + value.size(), number);
        if (!value.empty() && ec == std::errc() && ptr == value.data() + value.size() &&
            std::isfinite(number) && fits(number)) {
          return {};
        }
        return "expected " + what + ", got '" + value + "'";
      },
      description);
}

// %g: 0.001, 60, 1e-06.
std::string Short(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", x);
  return text;
}

}  // namespace

CLI::Validator PositiveNumber() {
  return Number([](double x) { return x > 0; }, "a number > 0");
}

CLI::Validator FiniteNumber() {
  return Number([](double) { return true; }, "a finite number");
}

CLI::Validator NumberIn(double minimum, double maximum) {
  const std::string range = "[" + Short(minimum) + ", " + Short(maximum) + "]";
  return Number([minimum, maximum](double x) { return x >= minimum && x <= maximum; },
                "a number in " + range, "NUMBER in " + range);
}

CLI::Option* AddSeedOption(CLI::App& app, std::function<void(uint64_t)> store,
                           const std::string& help) {
  return app
      .add_option_function<std::string>(
          "--seed",
          [store = std::move(store)](const std::string& text) {
            uint64_t value = 0;
            const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
            if (text.empty() || ec != std::errc() || ptr != text.data() + text.size()) {
              throw CLI::ValidationError("--seed",
                                         "expected a whole number >= 0, got '" + text + "'");
            }
            store(value);
          },
          help)
      ->type_name("S");
}

namespace {

// CLI11's help with the placeholders users expect: `--episodes N`, never `N:N` (CLI11 appends
// every validator's description to the type name) or a C++ type (`UINT`, `TEXT`). An option
// without a type name of its own shows N for a whole number, else its name in capitals
// (`--robot ROBOT`), a positional its name alone; a validator's description shows only when
// it says which values are allowed (`--type {objects,scenes,...}`, `--zstd-level N in [1 - 19]`).
class HelpFormatter : public CLI::Formatter {
 public:
  std::string make_option_opts(const CLI::Option* opt) const override {
    if (!opt->get_option_text().empty() || opt->get_type_size() == 0) {
      return Formatter::make_option_opts(opt);
    }
    const std::string placeholder = Placeholder(opt);
    std::string out = placeholder.empty() ? "" : " " + placeholder;
    if (!opt->get_default_str().empty()) out += "=" + opt->get_default_str();
    if (opt->get_expected_max() == CLI::detail::expected_max_vector_size) {
      out += " ...";
    } else if (opt->get_expected_min() > 1) {
      out += " x " + std::to_string(opt->get_expected());
    }
    if (opt->get_required()) out += " REQUIRED";
    if (!opt->get_envname().empty()) out += " (Env:" + opt->get_envname() + ")";
    if (!opt->get_needs().empty()) {
      out += " Needs:";
      for (const CLI::Option* o : opt->get_needs()) out += " " + o->get_name();
    }
    if (!opt->get_excludes().empty()) {
      out += " Excludes:";
      for (const CLI::Option* o : opt->get_excludes()) out += " " + o->get_name();
    }
    return out;
  }

 private:
  static std::string Placeholder(const CLI::Option* opt) {
    std::string type = opt->get_type_name();
    // Validator descriptions, taken off the end of the type name (get_type_name appends
    // ":<description>" for each non-empty one, in this order).
    std::vector<std::string> described;
    auto* mut = const_cast<CLI::Option*>(opt);  // get_validator(int) is not const
    for (int i = 0;; ++i) {
      const CLI::Validator* v = nullptr;
      try {
        v = mut->get_validator(i);
      } catch (const CLI::OptionNotFound&) {
        break;
      }
      if (!v->get_description().empty()) described.push_back(v->get_description());
    }
    for (auto it = described.rbegin(); it != described.rend(); ++it) {
      if (type.size() > it->size() && type.ends_with(":" + *it)) {
        type.resize(type.size() - it->size() - 1);
      }
    }
    static const std::vector<std::string> kCxxTypes = {"TEXT",   "INT",  "UINT",    "FLOAT",
                                                       "NUMBER", "ENUM", "BOOLEAN", "INT (bool)"};
    const bool positional = opt->get_lnames().empty() && opt->get_snames().empty();
    if (type == "INT" || type == "UINT") {
      type = "N";
    } else if (std::find(kCxxTypes.begin(), kCxxTypes.end(), type) != kCxxTypes.end()) {
      std::string name = !opt->get_lnames().empty()   ? opt->get_lnames().front()
                         : !opt->get_snames().empty() ? opt->get_snames().front()
                                                      : "";
      for (char& c : name) c = c == '-' ? '_' : static_cast<char>(std::toupper(c));
      type = name;
    }
    if (positional) type.clear();  // "CONFIG REQUIRED", not "CONFIG TEXT REQUIRED"
    for (const std::string& d : described) {
      if (d.starts_with("{")) {
        type = d;  // the allowed values
      } else if (const size_t in = d.find(" in ["); in != std::string::npos) {
        type += d.substr(in);  // a range
      }
    }
    return type;
  }
};

// The first flag typed (argv order) that the chosen command does not know, as
// "--epsiodes: unknown flag of datagen (did you mean '--episodes'?)" ("of render scene" for a
// nested command); empty when every flag is known (CLI11's message then says what is wrong).
// As for CLI11, a word starting with '-' is a flag unless it is a number, and nothing after
// "--" is.
std::string UnknownFlag(CLI::App& app, int argc, char** argv) {
  const auto [scope, command, first] = FindCommand(app, argc, argv);
  std::vector<std::string> longs, shorts;
  for (const CLI::Option* opt : scope->get_options()) {
    for (const std::string& n : opt->get_lnames()) longs.push_back("--" + n);
    for (const std::string& n : opt->get_snames()) shorts.push_back("-" + n);
  }
  for (int i = first; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--") break;
    if (arg.size() < 2 || arg[0] != '-' || std::isdigit(static_cast<unsigned char>(arg[1])) ||
        arg[1] == '.') {
      continue;  // a positional, a value or a negative number
    }
    const bool is_long = arg[1] == '-';
    // "--x=V" and "-xV" hold their value.
    const std::string name(is_long ? arg.substr(0, arg.find('=')) : arg.substr(0, 2));
    if (const CLI::Option* opt = scope->get_option_no_throw(name)) {
      // "-qv": flags without values; "-quiet" is not ("-u" is unknown).
      bool known = true;
      if (!is_long && opt->get_expected_max() == 0) {
        for (const char c : arg.substr(1, arg.find('=') - 1)) {
          known = known && scope->get_option_no_throw(std::string{'-', c}) != nullptr;
        }
      }
      if (known) continue;
    }
    // "-Q" is compared with the short flags ("-q"), "-quiet" and "--qiuet" with the long ones.
    const std::string typed(is_long ? name : std::string(arg.substr(0, arg.find('='))));
    const size_t dashes = std::min(typed.find_first_not_of('-'), typed.size());
    const std::string hint = typed.size() == 2
                                 ? mlspaces::DidYouMean(typed, shorts)
                                 : mlspaces::DidYouMean("--" + typed.substr(dashes), longs);
    std::string out = typed + ": unknown flag";
    if (!command.empty()) out += " of " + command;
    return out + (hint.empty() ? "" : " (" + hint + ")");
  }
  return {};
}

// The first flag or positional of the chosen commands given an empty value ("--out ''"), as
// "--out: empty value"; empty when there is none. No value here means "not given": a file,
// name, number or choice is never the empty string.
std::string EmptyValue(CLI::App& app) {
  for (CLI::App* scope = &app; scope != nullptr;) {
    for (const CLI::Option* opt : scope->get_options()) {
      if (opt->get_expected_min() == 0 || opt->count() == 0) continue;  // a flag, or not given
      for (const std::string& value : opt->results()) {
        if (value.empty()) return opt->get_name() + ": empty value";
      }
    }
    const std::vector<CLI::App*> chosen = scope->get_subcommands();
    scope = chosen.empty() ? nullptr : chosen.front();
  }
  return {};
}

}  // namespace

std::shared_ptr<CLI::Formatter> MakeHelpFormatter() { return std::make_shared<HelpFormatter>(); }

ChosenCommand FindCommand(CLI::App& app, int argc, char** argv) {
  ChosenCommand c{&app, "", 1};
  for (; c.next < argc && argv[c.next][0] != '-'; ++c.next) {
    CLI::App* sub = nullptr;
    for (CLI::App* s : c.scope->get_subcommands([](CLI::App*) { return true; })) {
      if (s->get_name() == argv[c.next]) sub = s;
    }
    if (sub == nullptr) break;
    c.scope = sub;
    c.path += (c.path.empty() ? "" : " ") + sub->get_name();
  }
  return c;
}

int ParseAndRun(CLI::App& app, const Action& action, int argc, char** argv) {
  try {
    app.parse(argc, argv);
    if (const std::string empty = EmptyValue(app); !empty.empty()) {
      std::fprintf(stderr, "mlspaces: error: %s (see --help)\n", empty.c_str());
      return 2;
    }
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // A misspelled flag: name the first one typed, with the flag it was probably meant to be.
    const std::string unknown = UnknownFlag(app, argc, argv);
    std::fprintf(stderr, "mlspaces: error: %s (see --help)\n",
                 Printable(unknown.empty() ? e.what() : unknown).c_str());
    return 2;
  }
  // Every error line is escaped (Printable): file names, flag values, JSON strings and UIDs
  // from input may hold control characters that would move the cursor or break the line.
  try {
    CrashPointCount();  // a malformed MLSPACES_CRASH_* fails here, before any work
    return action ? action() : 2;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "mlspaces: error: %s\n", Printable(e.what()).c_str());
    return 2;
  } catch (const Error& e) {
    std::fprintf(stderr, "mlspaces: error: %s\n", Printable(e.what()).c_str());
    return 1;
  } catch (const std::exception& e) {
    // The libraries throw mlspaces::Error (MuJoCo's sim::MujocoError included) for every bad
    // input; what arrives here is a bug (a std::logic_error bug check) or out of memory.
    std::fprintf(stderr, "mlspaces: internal error: %s\n", Printable(e.what()).c_str());
    return 1;
  }
}

}  // namespace mlspaces::cli
