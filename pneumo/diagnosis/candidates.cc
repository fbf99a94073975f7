// The candidate library's entry points (candidates.h): the forms come from the effect families of
// diagnosis/effects/ (registry.cc); here, the MJCF edits a form needs, made on the model's document
// (tinyxml2) with its includes resolved, and the model loaded from it.
#include "diagnosis/candidates.h"

#include <strings.h>

#include <string>
#include <utility>
#include <vector>

#include <tinyxml2.h>

#include "diagnosis/effects/registry.h"
#include "formats/model_loading.h"
#include "pneumatic/pneumatic.h"

namespace pneumatic::diagnosis {
namespace {

using tinyxml2::XMLDocument;
using tinyxml2::XMLElement;
using tinyxml2::XMLNode;

// the directory of a file's path with its separator, "" for a bare name: what MuJoCo 2.2 puts
// before the name of a file the model includes (mjuu_getfiledir)
std::string Directory(const std::string& path) {
  const size_t slash = path.find_last_of("/\\");
  return slash == std::string::npos ? "" : path.substr(0, slash + 1);
}

// Parses the XML file at `path`, `what` ("the model", "the included file 'NAME'"), into *doc: "" or
// why not.
std::string ParseFile(const std::string& path, const std::string& what, XMLDocument* doc) {
  const tinyxml2::XMLError status = doc->LoadFile(path.c_str());
  if (status == tinyxml2::XML_ERROR_FILE_NOT_FOUND || status == tinyxml2::XML_ERROR_FILE_COULD_NOT_BE_OPENED ||
      status == tinyxml2::XML_ERROR_FILE_READ_ERROR) {
    return "cannot read " + what;
  }
  if (status != tinyxml2::XML_SUCCESS) return what + ": XML parse error: " + doc->ErrorStr();
  return "";
}

// Replaces every <include file="..."/> below `element` by the child elements of the included file's
// root element (<mujoco>), as MuJoCo 2.2 assembles a model before parsing it (xml.cc, mjIncludeXML):
// the file named relative to the main model's directory `dir` (nested includes too), no children
// of its own, each file at most once in the model (`included`, names compared without case as
// MuJoCo does, the main model's first), included elements resolved in turn. "" or why not.
std::string ResolveIncludes(XMLElement* element, const std::string& dir, std::vector<std::string>* included) {
  for (XMLElement* child = element->FirstChildElement(); child;) {
    if (strcasecmp(child->Value(), "include") != 0) {
      if (std::string why = ResolveIncludes(child, dir, included); !why.empty()) return why;
      child = child->NextSiblingElement();
      continue;
    }
    const char* file = child->Attribute("file");
    if (!file) return "an <include> element without a file attribute";
    if (!child->NoChildren()) return std::string("<include file=\"") + file + "\"> has children";
    const std::string name = dir + file;
    for (const std::string& other : *included) {
      if (strcasecmp(other.c_str(), name.c_str()) == 0) return "file '" + name + "' already included";
    }
    XMLDocument source;
    if (std::string why = ParseFile(name, "the included file '" + name + "'", &source); !why.empty()) return why;
    included->push_back(name);
    const XMLElement* root = source.RootElement();
    if (!root || !root->FirstChildElement()) return "included file '" + name + "' has no elements below its root";
    // the included elements in its place, in their order; then resolved themselves
    XMLNode* at = child;
    XMLElement* first = nullptr;
    for (const XMLElement* e = root->FirstChildElement(); e; e = e->NextSiblingElement()) {
      at = element->InsertAfterChild(at, e->DeepClone(element->GetDocument()));
      if (!first) first = at->ToElement();
    }
    element->DeleteChild(child);
    child = first;
  }
  return "";
}

// the <text name="NAME"> of the model's <custom> sections, or null
XMLElement* CustomText(XMLElement* mujoco, const std::string& name) {
  for (XMLElement* custom = mujoco->FirstChildElement("custom"); custom; custom = custom->NextSiblingElement("custom")) {
    for (XMLElement* text = custom->FirstChildElement("text"); text; text = text->NextSiblingElement("text")) {
      if (const char* n = text->Attribute("name"); n && name == n) return text;
    }
  }
  return nullptr;
}

// the actuator named NAME of the model's <actuator> sections, or null
XMLElement* Actuator(XMLElement* mujoco, const std::string& name) {
  for (XMLElement* section = mujoco->FirstChildElement("actuator"); section; section = section->NextSiblingElement("actuator")) {
    for (XMLElement* actuator = section->FirstChildElement(); actuator; actuator = actuator->NextSiblingElement()) {
      if (const char* n = actuator->Attribute("name"); n && name == n) return actuator;
    }
  }
  return nullptr;
}

// <general name="NAME" TRANSMISSION="TARGET" KEY="user" .../>: an actuator of the extension on a
// cylinder's transmission, its roles given by the user types `user_types` (dyntype, gaintype, biastype)
XMLElement* UserActuator(XMLDocument* doc, const std::string& name, const std::pair<std::string, std::string>& transmission,
                         const std::vector<const char*>& user_types) {
  XMLElement* actuator = doc->NewElement("general");
  actuator->SetAttribute("name", name.c_str());
  actuator->SetAttribute(transmission.first.c_str(), transmission.second.c_str());
  for (const char* type : user_types) actuator->SetAttribute(type, "user");
  return actuator;
}

// The edit's actuators: state actuators (and a new reservoir's NAME.pressure) after every other
// actuator (MuJoCo 2.2 wants stateless actuators first: the last <actuator> section's end), force
// actuators before every other (the first section's start), all on the transmission of the
// cylinder's chamber P actuator (its joint, tendon or jointinparent). "" or why not.
std::string AddActuators(XMLElement* mujoco, const ModelEdit& e, bool new_reservoir) {
  XMLDocument* doc = mujoco->GetDocument();
  const XMLElement* chamber = Actuator(mujoco, e.cylinder + ".P");
  std::pair<std::string, std::string> transmission;
  for (const char* attribute : {"joint", "tendon", "jointinparent"}) {
    if (const char* target = chamber ? chamber->Attribute(attribute) : nullptr) transmission = {attribute, target};
  }
  XMLElement* first = mujoco->FirstChildElement("actuator");
  XMLElement* last = mujoco->LastChildElement("actuator");
  if (transmission.first.empty() || !last) {
    return "cannot find the transmission of actuator '" + e.cylinder + ".P' to add the effect's states";
  }
  for (const std::string& suffix : e.state_actuators) {
    last->InsertEndChild(UserActuator(doc, e.cylinder + "." + suffix, transmission, {"dyntype", "gaintype"}));
  }
  if (new_reservoir) last->InsertEndChild(UserActuator(doc, e.reservoir + ".pressure", transmission, {"dyntype", "gaintype"}));
  XMLNode* previous = nullptr;
  for (const std::string& suffix : e.force_actuators) {
    XMLElement* force = UserActuator(doc, e.cylinder + "." + suffix, transmission, {"gaintype", "biastype"});
    previous = previous ? first->InsertAfterChild(previous, force) : first->InsertFirstChild(force);
  }
  return "";
}

// Applies one edit to the model's document (includes resolved): "" or why not.
std::string ApplyEdit(XMLElement* mujoco, const ModelEdit& e) {
  // keys: appended to the data attribute of <text name="pneumatic:CYL" data="...">
  XMLElement* text = CustomText(mujoco, "pneumatic:" + e.cylinder);
  if (!text || !text->Attribute("data")) {
    return "no <text name=\"pneumatic:" + e.cylinder + "\" data=\"...\"> element to edit";
  }
  // a reservoir that feeds several cylinders is added with the first edit that names it
  const bool new_reservoir = !e.reservoir.empty() && !CustomText(mujoco, "pneumatic_reservoir:" + e.reservoir);
  std::string added;
  for (const auto& [key, value] : e.keys) added += " " + key + "=" + value;
  if (!e.reservoir.empty()) added += " supply=" + e.reservoir;
  text->SetAttribute("data", (text->Attribute("data") + added).c_str());
  for (const std::string& suffix : e.stateful_commands) {
    XMLElement* command = Actuator(mujoco, e.cylinder + "." + suffix);
    if (!command || command->Attribute("dyntype")) {
      return "cannot give actuator '" + e.cylinder + "." + suffix + "' a state (not found, or it has a dyntype)";
    }
    command->SetAttribute("dyntype", "user");
  }
  if (new_reservoir) {
    // <text name="pneumatic_reservoir:NAME" data="KEY=VALUE ..."/>, first in the first <custom>
    XMLElement* custom = mujoco->FirstChildElement("custom");
    if (!custom) custom = mujoco->InsertNewChildElement("custom");
    std::string keys;
    for (const auto& [key, value] : e.reservoir_keys) keys += (keys.empty() ? "" : " ") + key + "=" + value;
    XMLElement* reservoir = mujoco->GetDocument()->NewElement("text");
    reservoir->SetAttribute("name", ("pneumatic_reservoir:" + e.reservoir).c_str());
    reservoir->SetAttribute("data", keys.c_str());
    custom->InsertFirstChild(reservoir);
  }
  if (!e.state_actuators.empty() || !e.force_actuators.empty() || new_reservoir) return AddActuators(mujoco, e, new_reservoir);
  return "";
}

}  // namespace

std::vector<std::string> DelayLineStates(const std::string& valve) {
  if (valve == "proportional_5_3") return {"d1", "d2"};
  if (valve == "proportional_per_chamber") return {"dP1", "dP2", "dN1", "dN2"};
  return {};
}

std::string RefreshMassConstants(mjModel* m) {
  mjData* d = mj_makeData(m);
  if (!d) return "mj_makeData failed";
  mj_setConst(m, d);
  mj_deleteData(d);
  return "";
}

const std::vector<std::string>& EffectNames() {
  static const std::vector<std::string> names = {"valve_delay",  "valve_deadband", "friction", "leakage",
                                                 "heat_transfer", "supply_drop",   "line_dynamics", "payload",
                                                 "sensor_bias",  "none"};
  return names;
}

void SkipCollisionWhereNothingCollides(mjModel* m) {
  if (m->npair > 0) return;
  int contype = 0, conaffinity = 0;
  for (int g = 0; g < m->ngeom; ++g) contype |= m->geom_contype[g], conaffinity |= m->geom_conaffinity[g];
  if ((contype & conaffinity) == 0) m->opt.disableflags |= mjDSBL_CONTACT;
}

ModelPtr LoadEditedModel(const std::string& path, const std::vector<ModelEdit>& edits, std::string* error) {
  auto fail = [&](const std::string& why) {
    *error = path + ": " + why;
    return ModelPtr(nullptr, mj_deleteModel);
  };
  XMLDocument doc;
  if (std::string why = ParseFile(path, "the model", &doc); !why.empty()) return fail(why);
  XMLElement* mujoco = doc.RootElement();
  if (!mujoco) return fail("the model has no root element");
  std::vector<std::string> included = {path};
  if (strcasecmp(mujoco->Value(), "mujoco") == 0) {
    if (std::string why = ResolveIncludes(mujoco, Directory(path), &included); !why.empty()) return fail(why);
  }
  for (const ModelEdit& e : edits) {
    if (std::string why = ApplyEdit(mujoco, e); !why.empty()) return fail(why);
  }
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  const std::string xml = printer.CStr();
  // a virtual file beside the original: MuJoCo looks it up first, and resolves assets relative to
  // the original's directory (the includes are in the text already)
  const std::string virtual_name = path.substr(0, path.rfind('.')) + ".diagnosis.xml";
  std::string load_error;
  ModelPtr m = LoadModelFromText(xml, virtual_name, &load_error);
  if (!m) {
    *error = path + " with the effect's edits: " + load_error;
    return m;
  }
  std::string attach_error;
  if (!Attach(m.get(), &attach_error)) {
    *error = path + " with the effect's edits: " + attach_error;
    return ModelPtr(nullptr, mj_deleteModel);
  }
  SkipCollisionWhereNothingCollides(m.get());
  return m;
}

std::vector<Candidate> CandidateLibrary(const mjModel* m, const Measurements& meas) {
  return effects::RegisteredForms(m, meas);
}

}  // namespace pneumatic::diagnosis
