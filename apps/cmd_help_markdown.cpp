// `ccfr help-markdown [--readme-table | --stats-columns]` (hidden): the command reference, docs/cli.md, and the
// README's command table, generated from the same CLI11 definitions `--help` prints, so that help and
// docs cannot disagree (scripts/gen-cli-docs writes both; tests/apps/test_cli_docs.cpp checks them);
// `--stats-columns`: docs/output.md's stats.csv column table, from kStatsColumns (tests/io/test_stats_csv.cpp).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "ccfr/io/stats_csv.hpp"
#include "commands.hpp"
#include "exit_codes.hpp"

namespace ccfr::app {

namespace {

// Options every command accepts (main.cpp) are documented once, under "Global options".
bool is_global(const CLI::Option* o) {
  return o->check_lname("log-level") || o->check_lname("quiet") || o->check_lname("help") || o->check_lname("version");
}

bool hidden(const CLI::Option* o) { return o->get_group().empty(); }

// Table cells hold option text; a | would end the cell.
std::string cell(std::string s) {
  std::string o;
  for (char c : s) o += c == '|' ? std::string("\\|") : std::string(1, c);
  return o;
}

// "-f, --format" / "--no-plot" / "CONFIG".
std::string upper(std::string s) {
  for (char& c : s)
    if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 'a' + 'A');
  return s;
}

std::string names(const CLI::Option* o) {
  if (!o->nonpositional()) return upper(o->get_name(true, false));
  std::string s;
  for (const auto& n : o->get_snames()) s += (s.empty() ? "-" : ", -") + n;
  for (const auto& n : o->get_lnames()) s += (s.empty() ? "--" : ", --") + n;
  return s;
}

// What the option takes: nothing for a flag, else CLI11's type and checks (TEXT, UINT:POSITIVE, ...).
std::string value(const CLI::Option* o) {
  std::string t = o->get_type_name();
  if (t.empty()) return "(flag)";
  if (o->get_items_expected_max() > 1) t += " ...";
  return t;
}

std::vector<const CLI::Option*> documented_options(const CLI::App& cmd) {
  return cmd.get_options([](const CLI::Option* o) { return !hidden(o) && !is_global(o); });
}

std::vector<const CLI::App*> visible_subcommands(const CLI::App& app) {
  std::vector<const CLI::App*> out;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App* s) { return !s->get_group().empty(); }))
    out.push_back(sub);
  return out;
}

// "ccfr sweep status" for a subcommand, and its GitHub anchor "ccfr-sweep-status".
std::string full_name(const CLI::App& cmd) {
  return cmd.get_parent() ? full_name(*cmd.get_parent()) + " " + cmd.get_name() : std::string("ccfr");
}
std::string anchor(const CLI::App& cmd) {
  std::string a = full_name(cmd);
  for (char& c : a)
    if (c == ' ') c = '-';
  return a;
}

// "ccfr run [CONFIG] [OPTIONS]": positionals in their order, required ones without brackets.
std::string usage(const CLI::App& cmd) {
  std::string u = full_name(cmd);
  for (const CLI::Option* o : cmd.get_options([](const CLI::Option* o) { return !o->nonpositional(); })) {
    const std::string n = upper(o->get_name(true, false));
    u += o->get_required() ? " " + n : " [" + n + "]";
  }
  if (!documented_options(cmd).empty()) u += " [OPTIONS]";
  if (!visible_subcommands(cmd).empty()) u += " | " + full_name(cmd) + " SUBCOMMAND ...";
  return u;
}

void command_section(const CLI::App& cmd, int level, std::string& md) {
  md += "\n" + std::string(static_cast<size_t>(level), '#') + " " + full_name(cmd) + "\n\n";
  md += cmd.get_description() + "\n\n```\n" + usage(cmd) + "\n```\n";
  const auto opts = documented_options(cmd);
  if (!opts.empty()) {
    md += "\n| argument | value | default | meaning |\n|---|---|---|---|\n";
    for (const CLI::Option* o : opts) {
      std::string def = o->get_default_str();
      md += "| `" + cell(names(o)) + "`" + (o->get_required() ? " (required)" : "") + " | " + cell(value(o)) + " | " +
            (def.empty() ? "" : "`" + cell(def) + "`") + " | " + cell(o->get_description()) + " |\n";
    }
  }
  for (const CLI::App* sub : visible_subcommands(cmd)) command_section(*sub, level + 1, md);
}

std::string reference(const CLI::App& root) {
  std::string md =
      "# Command reference\n\n"
      "<!-- Generated from the CLI11 definitions in apps/ by `ccfr help-markdown` (scripts/gen-cli-docs); do not\n"
      "     edit: tests/apps/test_cli_docs.cpp fails when this file and the program differ. -->\n\n" +
      root.get_description() +
      ". Every command prints this help with `--help`, with the global options and these exit codes (`ccfr run` "
      "and the sweeps document more: [output.md](output.md), [cluster.md](cluster.md)):\n\n" +
      exit_code_markdown() + "\n| command | does |\n|---|---|\n";
  for (const CLI::App* sub : visible_subcommands(root))
    md += "| [`" + full_name(*sub) + "`](#" + anchor(*sub) + ") | " + cell(sub->get_description()) + " |\n";
  md += "\n## Global options\n\nAccepted before or after any command.\n\n| option | value | meaning |\n|---|---|---|\n";
  for (const CLI::Option* o : root.get_options([](const CLI::Option* o) { return !hidden(o) && is_global(o); }))
    md += "| `" + cell(names(o)) + "` | " + cell(value(o)) + " | " + cell(o->get_description()) + " |\n";
  for (const CLI::App* sub : visible_subcommands(root)) command_section(*sub, 2, md);
  return md;
}

// The README's table: one row per command and sweep subcommand, linking to docs/cli.md.
std::string readme_table(const CLI::App& root) {
  std::string md = "| command | does |\n|---|---|\n";
  auto row = [&md](const CLI::App& cmd) {
    md += "| [`" + cell(usage(cmd)) + "`](docs/cli.md#" + anchor(cmd) + ") | " + cell(cmd.get_description()) + " |\n";
  };
  for (const CLI::App* sub : visible_subcommands(root)) {
    row(*sub);
    for (const CLI::App* nested : visible_subcommands(*sub)) row(*nested);
  }
  return md;
}

}  // namespace

void register_help_markdown(CLI::App& app) {
  auto table = std::make_shared<bool>(false), stats = std::make_shared<bool>(false);
  auto* cmd = app.add_subcommand("help-markdown", "Print the command reference (docs/cli.md) as Markdown");
  cmd->group("");  // internal: the generator of docs/cli.md, the README's table and docs/output.md's columns
  cmd->add_flag("--readme-table", *table, "Print the README's command table instead");
  cmd->add_flag("--stats-columns", *stats, "Print docs/output.md's table of the stats.csv columns instead")
      ->excludes("--readme-table");
  CLI::App* root = &app;
  cmd->callback([root, table, stats] {
    guarded([root, table, stats] {
      const std::string md = *stats ? io::stats_columns_markdown() : *table ? readme_table(*root) : reference(*root);
      std::fputs(md.c_str(), stdout);
      return 0;
    });
  });
}

}  // namespace ccfr::app
