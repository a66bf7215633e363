#include "scenenet.h"

#include <algorithm>
#include <array>
#include <string>
#include <utility>

namespace solid::convert {
namespace {

// nyu_idset.csv, ids 0..40 in order.
constexpr std::array<std::string_view, 41> kNyuLabels = {
    "void",       "wall",      "floor",       "cabinet",       "bed",          "chair",       "sofa",
    "table",      "door",      "window",      "bookshelf",     "picture",      "counter",     "blinds",
    "desk",       "shelves",   "curtain",     "dresser",       "pillow",       "mirror",      "floor_mat",
    "clothes",    "ceiling",   "books",       "refridgerator", "television",   "paper",       "towel",
    "shower_curtain", "box",   "whiteboard",  "person",        "night_stand",  "toilet",      "sink",
    "lamp",       "bathtub",   "bag",         "otherstructure", "otherfurniture", "otherprop"};

// BlenderProc's NORMALIZE table (its "Other-*" keys can never match a lower-cased name).
constexpr std::array<std::pair<std::string_view, std::string_view>, 12> kNormalize = {{
    {"floor-mat", "floor_mat"},
    {"refrigerator", "refridgerator"},
    {"shower-curtain", "shower_curtain"},
    {"nightstand", "night_stand"},
    {"floor_tiles_floor_tiles_0125", "floor"},
    {"ground", "floor"},
    {"floor_enclose", "floor"},
    {"floor_enclose2", "floor"},
    {"floor_base_object01_56", "floor"},
    {"walls1_line01_12", "wall"},
    {"room_skeleton", "wall"},
    {"ceilingwall", "ceiling"},
}};

std::string Lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(c >= 'A' && c <= 'Z' ? c + 32 : c); });
  return out;
}

int LabelId(std::string_view label) {
  for (size_t i = 0; i < kNyuLabels.size(); ++i) {
    if (kNyuLabels[i] == label) return static_cast<int>(i);
  }
  return -1;
}

}  // namespace

int SceneNetCategory(std::string_view object_name) {
  std::string n = Lower(object_name);
  n = n.substr(0, n.find('.'));
  for (const auto& [from, to] : kNormalize) {
    if (n == from) {
      n = to;
      break;
    }
  }
  if (int id = LabelId(n); id >= 0) return id;
  if (!n.empty()) {
    if (int id = LabelId(std::string_view(n).substr(0, n.size() - 1)); id >= 0) return id;
  }
  if (n.find("painting") != std::string::npos) return 11;
  return 38;
}

std::string_view StructureName(Structure s) {
  switch (s) {
    case Structure::kNone: return "";
    case Structure::kWall: return "wall";
    case Structure::kFloor: return "floor";
    case Structure::kCeiling: return "ceiling";
  }
  return "";
}

Structure SceneNetStructure(std::string_view object_name) {
  int category = SceneNetCategory(object_name);
  std::string lower = Lower(object_name);
  if (category == 1) return Structure::kWall;
  if (category == 2 || lower.find("floor") != std::string::npos) return Structure::kFloor;
  if (category == 22 || lower.find("ceiling") != std::string::npos) return Structure::kCeiling;
  return Structure::kNone;
}

std::string SceneNetTextureFolder(std::string_view material_name) {
  std::string folder;
  for (char c : material_name.substr(0, material_name.find('.'))) {
    if (c != '_' && !(c >= '0' && c <= '9')) folder += c;
  }
  return folder;
}

}  // namespace solid::convert
