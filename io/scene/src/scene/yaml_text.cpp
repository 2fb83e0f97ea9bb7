// The text of a scene file before its keys are read: printable, one YAML document, quotes
// closed, nesting and alias expansion bounded (yaml-cpp would loop, recurse or allocate without end).
#include <cstdint>
#include <cstdio>
#include <map>
#include <sstream>

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>

#include "ccfr/core/error.hpp"
#include "ccfr/io/user_file.hpp"
#include "input.hpp"

namespace ccfr::io::scene {

namespace {

/// A quoted scalar whose closing quote is missing swallows the rest of the file (yaml-cpp accepts
/// it at the end of the input): find the quoted scalars of the tree and check that each closes.
void check_quotes(const YAML::Node& n, const std::string& text, const std::string& label) {
  if (n.IsMap()) {
    for (auto it = n.begin(); it != n.end(); ++it) {
      check_quotes(it->first, text, label);
      check_quotes(it->second, text, label);
    }
  } else if (n.IsSequence()) {
    for (const auto& c : n) check_quotes(c, text, label);
  } else if (n.IsScalar() && !n.Mark().is_null() && n.Mark().pos >= 0) {
    const size_t pos = static_cast<size_t>(n.Mark().pos);
    if (pos >= text.size() || (text[pos] != '"' && text[pos] != '\'')) return;
    const char q = text[pos];
    for (size_t i = pos + 1; i < text.size(); ++i) {
      if (q == '"' && text[i] == '\\')
        ++i;
      else if (text[i] == q) {
        if (q == '\'' && i + 1 < text.size() && text[i + 1] == '\'')
          ++i;  // '' inside single quotes
        else
          return;
      }
    }
    throw ConfigError(label, "", n.Mark().line + 1,
                      std::string("YAML syntax error: unterminated ") + (q == '"' ? "double" : "single") +
                          "-quoted string (the closing " + q + " is missing)");
  }
}

/// Deepest nesting of collections in a scene file: the schema's deepest key path is a few levels;
/// yaml-cpp itself stops at 2000 with "bad file", and walks that deep recurse for every reader.
constexpr int kMaxYamlDepth = 64;
/// Most nodes a scene may expand to, counting each alias as the nodes it stands for: a 4 MiB
/// file holds at most about 2 million nodes written out, so only an alias bomb (nine levels of
/// ten aliases each: 10^9 nodes from 500 bytes) goes beyond, and every reader would walk them all.
constexpr std::uint64_t kMaxYamlNodes = std::uint64_t{1} << 21;

/// Walks the documents of a YAML stream without building nodes. yaml-cpp 0.7's `LoadAll` loops
/// forever (allocating an empty document per turn) on a token its parser cannot start a node with,
/// e.g. a leading ',': each document then starts at the same mark. This counter stops there.
/// It also bounds the nesting depth and the node count with aliases expanded (see above).
class DocumentScan : public YAML::EventHandler {
 public:
  /// Start mark of each document seen, and where its first non-null node starts (if any).
  struct Doc {
    YAML::Mark start;
    bool content = false;
    YAML::Mark first;
  };
  std::vector<Doc> docs;

  explicit DocumentScan(std::string label) : label_(std::move(label)) {}

  void OnDocumentStart(const YAML::Mark& mark) override {
    docs.push_back({mark, false, mark});
    open_.clear();
    expanded_ = 0;
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& m, YAML::anchor_t anchor) override { leaf(m, anchor, 1); }
  void OnAlias(const YAML::Mark& m, YAML::anchor_t anchor) override {
    seen(m);
    // yaml-cpp links an alias inside its own anchor's node into a cycle: every walk of the tree
    // would recurse until the stack overflows.
    for (const Open& o : open_)
      if (o.anchor == anchor)
        throw ConfigError(label_, "", m.line + 1,
                          "an alias refers to the list or map it is inside (opened on line " +
                              std::to_string(o.mark.line + 1) + "): the node would contain itself");
    const auto it = size_of_.find(anchor);
    leaf(m, 0, it == size_of_.end() ? 1 : it->second);
  }
  void OnScalar(const YAML::Mark& m, const std::string&, YAML::anchor_t anchor, const std::string&) override {
    seen(m);
    leaf(m, anchor, 1);
  }
  void OnSequenceStart(const YAML::Mark& m, const std::string&, YAML::anchor_t anchor,
                       YAML::EmitterStyle::value) override {
    seen(m);
    start(m, anchor);
  }
  void OnSequenceEnd() override { end(); }
  void OnMapStart(const YAML::Mark& m, const std::string&, YAML::anchor_t anchor, YAML::EmitterStyle::value) override {
    seen(m);
    start(m, anchor);
  }
  void OnMapEnd() override { end(); }

 private:
  struct Open {
    YAML::anchor_t anchor;
    std::uint64_t size;
    YAML::Mark mark;
  };

  void seen(const YAML::Mark& m) {
    if (!docs.back().content) docs.back().first = m;
    docs.back().content = true;
  }
  void start(const YAML::Mark& m, YAML::anchor_t anchor) {
    if (open_.size() >= static_cast<size_t>(kMaxYamlDepth))
      throw ConfigError(label_, "", m.line + 1,
                        "YAML nesting too deep: more than " + std::to_string(kMaxYamlDepth) +
                            " levels of lists and maps (a scene needs a few)");
    open_.push_back({anchor, 1, m});
    count(m, 1);
  }
  void end() {
    const Open o = open_.back();
    open_.pop_back();
    if (o.anchor) size_of_[o.anchor] = o.size;
    if (!open_.empty()) open_.back().size += o.size;
  }
  /// A node of `size` expanded nodes (1, or an alias's target).
  void leaf(const YAML::Mark& m, YAML::anchor_t anchor, std::uint64_t size) {
    if (anchor) size_of_[anchor] = size;
    if (!open_.empty()) open_.back().size += size;
    count(m, size);
  }
  void count(const YAML::Mark& m, std::uint64_t size) {
    expanded_ += size;
    if (expanded_ > kMaxYamlNodes)
      throw ConfigError(label_, "", m.line + 1,
                        "the scene expands to more than " + std::to_string(kMaxYamlNodes) +
                            " YAML nodes (aliases counted as the nodes they repeat); is this an alias bomb?");
  }

  std::string label_;
  std::vector<Open> open_;
  std::map<YAML::anchor_t, std::uint64_t> size_of_;
  std::uint64_t expanded_ = 0;
};

}  // namespace

/// Parses the text of a scene file: printable text, one YAML document, every quoted string closed.
YAML::Node parse_yaml(const std::string& text, const std::string& label, const std::string& what) {
  if (text.size() > kMaxSceneFileBytes)
    throw ConfigError(label, "", 0,
                      "the " + what + " has " + std::to_string(text.size()) + " bytes; it is limited to " +
                          std::to_string(kMaxSceneFileBytes >> 20) +
                          " MiB (put meshes in .obj files and reference them with shape.path)");
  // YAML allows no C0 control character but tab, LF and CR; yaml-cpp reads NUL as end of input.
  int line = 1;
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (c == '\n') ++line;
    if ((c < 0x20 && c != '\t' && c != '\n' && c != '\r') || c == 0x7f) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "0x%02x", c);
      throw ConfigError(
          label, "", line,
          "the " + what + " is not text: control byte " + hex + " (YAML allows only tab, newline and carriage return)");
    }
  }
  DocumentScan scan(label);
  try {
    std::istringstream in(text);
    YAML::Parser parser(in);
    while (parser.HandleNextDocument(scan)) {
      const size_t n = scan.docs.size();
      if (n >= 2 && scan.docs[n - 1].start.pos == scan.docs[n - 2].start.pos) {
        const YAML::Mark& m = scan.docs[n - 1].start;
        const size_t pos = m.pos >= 0 ? static_cast<size_t>(m.pos) : 0;
        const std::string token = pos < text.size() ? std::string("'") + text[pos] + "'" : "end of input";
        throw ConfigError(label, "", m.line + 1,
                          "YAML syntax error: unexpected " + token + " at column " + std::to_string(m.column + 1) +
                              " (no YAML node starts with it)");
      }
      if (n >= 2 && scan.docs[n - 1].content)
        throw ConfigError(label, "", scan.docs[n - 1].first.line + 1,
                          "a " + what +
                              " holds one YAML document, but a second one starts here (after '---'); merge "
                              "them or remove it");
    }
  } catch (const YAML::ParserException& e) {
    throw ConfigError(label, "", e.mark.line + 1, "YAML syntax error: " + e.msg);
  }
  if (scan.docs.empty()) return YAML::Node();
  YAML::Node root;
  try {
    root = YAML::Load(text);  // the scan above proved it terminates: one well-formed first document
  } catch (const YAML::ParserException& e) {
    throw ConfigError(label, "", e.mark.line + 1, "YAML syntax error: " + e.msg);
  }
  check_quotes(root, text, label);
  return root;
}

}  // namespace ccfr::io::scene
