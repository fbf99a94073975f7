#include "formats/model_file.h"

#include <fstream>
#include <memory>
#include <sstream>

#include "formats/output_file.h"
#include "pneumatic/pneumatic.h"

namespace pneumatic {
namespace {

// the configuration text laid out as the shipped models write it: key=value pairs, lines of at
// most about 100 characters, continuation lines indented under the first
std::string Wrap(const std::string& text, const std::string& indent) {
  std::istringstream words(text);
  std::string word, out, line;
  while (words >> word) {
    if (!line.empty() && line.size() + 1 + word.size() > 90) {
      out += line + "\n" + indent;
      line.clear();
    }
    line += (line.empty() ? "" : " ") + word;
  }
  return out + line;
}

// replaces the data attribute of the element named "pneumatic:<cylinder>"; "" or the error
std::string ReplaceConfiguration(std::string* xml, const std::string& cylinder, const std::string& text,
                                 const std::string& note) {
  const std::string name = "pneumatic:" + cylinder;
  size_t at = std::string::npos;
  for (const char* quote : {"\"", "'"}) {
    if (at == std::string::npos) at = xml->find("name=" + std::string(quote) + name + quote);
  }
  if (at == std::string::npos) {
    return "cylinder '" + cylinder + "': its element <text name=\"" + name +
           "\"> is not in the model file itself (an included file?); write the model from the file that holds it";
  }
  const size_t tag = xml->rfind('<', at);
  const size_t tag_end = xml->find('>', at);
  size_t data = xml->find("data=", tag);
  if (tag == std::string::npos || data == std::string::npos || data > tag_end || data + 5 >= xml->size()) {
    return "cylinder '" + cylinder + "': element <text name=\"" + name + "\"> has no data attribute";
  }
  const char quote = (*xml)[data + 5];
  const size_t value = data + 6, value_end = xml->find(quote, value);
  if ((quote != '"' && quote != '\'') || value_end == std::string::npos) {
    return "cylinder '" + cylinder + "': cannot read the data attribute of <text name=\"" + name + "\">";
  }
  // the element's indentation, for the comment and the continuation lines
  const size_t line_start = xml->rfind('\n', tag) == std::string::npos ? 0 : xml->rfind('\n', tag) + 1;
  const std::string indent = xml->substr(line_start, tag - line_start);
  const bool indented_alone = indent.find_first_not_of(" \t") == std::string::npos;
  xml->replace(value, value_end - value, Wrap(text, (indented_alone ? indent : "") + "      "));
  if (!note.empty()) xml->insert(tag, "<!-- " + note + " -->\n" + (indented_alone ? indent : ""));
  return "";
}

// loads, attaches and steps the written model once; "" or why not
std::string CheckLoadsAndRuns(const std::string& path) {
  char error[1000] = "";
  std::unique_ptr<mjModel, void (*)(mjModel*)> m(mj_loadXML(path.c_str(), nullptr, error, sizeof(error)),
                                                 mj_deleteModel);
  if (!m) return path + ": the written model does not load: " + error;
  std::string attach_error;
  if (!Attach(m.get(), &attach_error)) return path + ": the written model does not attach: " + attach_error;
  std::unique_ptr<mjData, void (*)(mjData*)> d(mj_makeData(m.get()), mj_deleteData);
  mj_step(m.get(), d.get());
  for (int w = 0; w < mjNWARNING; ++w) {
    if (d->warning[w].number > 0) return path + ": the written model warns on its first step (MuJoCo warning " + std::to_string(w) + ")";
  }
  Detach(m.get());
  return "";
}

}  // namespace

std::string WriteModelWithParameters(const std::string& source_path, const mjModel* m, const std::string& out_path,
                                     const std::string& note) {
  std::ifstream in(source_path, std::ios::binary);
  if (!in) return source_path + ": cannot read the model file";
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string xml = buffer.str();
  for (const CylinderInfo& c : Cylinders(m)) {
    std::string error;
    std::optional<std::string> text = ConfigurationText(m, c.name, &error);
    if (!text) return error;
    if (std::string e = ReplaceConfiguration(&xml, c.name, *text, note); !e.empty()) return source_path + ": " + e;
  }
  if (std::string e = WriteOutput(out_path, xml, "a model file"); !e.empty()) return e;
  return CheckLoadsAndRuns(out_path);
}

}  // namespace pneumatic
