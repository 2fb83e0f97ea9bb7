#include "input.hpp"

#include <sstream>

#include "ccfr/io/user_file.hpp"

namespace ccfr::io::scene {

YAML::Node Input::in_node(const std::string& path) const {
  YAML::Node cur;
  cur.reset(in);
  std::string seg;
  std::stringstream ss(path);
  while (std::getline(ss, seg, '.')) {
    std::string key = seg;
    std::vector<size_t> idx;
    const auto br = seg.find('[');
    if (br != std::string::npos) {
      key = seg.substr(0, br);
      for (size_t b = br; b != std::string::npos; b = seg.find('[', b + 1))
        idx.push_back(std::stoul(seg.substr(b + 1)));
    }
    if (!cur.IsMap() || !cur[key]) return cur;
    YAML::Node next = cur[key];
    cur.reset(next);
    for (size_t k : idx) {
      if (!cur.IsSequence() || k >= cur.size()) return cur;
      YAML::Node nn = cur[k];
      cur.reset(nn);
    }
  }
  return cur;
}

std::string name_problem(const std::string& name, bool whitespace_matters) {
  if (std::string why = text_problem(name); !why.empty()) return why;  // run.json and the frames are UTF-8
  if (!whitespace_matters) return "";
  if (name.find_first_not_of(" ") == std::string::npos) return "is empty or only whitespace";
  if (name.front() == ' ' || name.back() == ' ') return "starts or ends with a space";
  return "";
}

}  // namespace ccfr::io::scene
