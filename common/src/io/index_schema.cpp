// The schema's small helpers (mocap/common/io/index.hpp, mocap/common/io/index_tables.hpp): row
// shapes, field lookup, the names of the stored enumerations.
#include <string>
#include <vector>

#include "mocap/common/io/index.hpp"
#include "mocap/common/io/index_tables.hpp"

namespace mocap {

std::size_t row_elements(RowShape s, std::size_t joints, std::size_t segments) {
  std::size_t n = 1;
  for (auto d : row_dims(s, joints, segments)) n *= d;
  return n;
}

std::vector<std::size_t> row_dims(RowShape s, std::size_t joints, std::size_t segments) {
  switch (s) {
    case RowShape::scalar:
      return {};
    case RowShape::vec3:
      return {3};
    case RowShape::joints3:
      return {joints, 3};
    case RowShape::joints4:
      return {joints, 4};
    case RowShape::segments3:
      return {segments, 3};
    case RowShape::segments9:
      return {segments, 9};
  }
  return {};
}

bool frame_field_stored(std::string_view name, std::int64_t schema_version) {
  for (const DerivedFrameField& d : kIndexDerivedFrameFields)
    if (d.name == name) return schema_version < d.since;
  return true;
}

int find_field(std::span<const IndexFieldSpec> table, std::string_view name) {
  for (std::size_t i = 0; i < table.size(); ++i)
    if (name == table[i].name) return static_cast<int>(i);
  return -1;
}

const char* clip_status_name(ClipStatus s) {
  switch (s) {
    case ClipStatus::parsed_new:
      return "new";
    case ClipStatus::parsed_changed:
      return "changed";
    case ClipStatus::reused:
      return "reused";
  }
  return "new";
}

const char* label_source_name(LabelSource s) {
  switch (s) {
    case LabelSource::none:
      return "none";
    case LabelSource::file_name:
      return "file_name";
    case LabelSource::sidecar:
      return "sidecar";
    case LabelSource::sidecar_cfg:
      return "sidecar_cfg";
  }
  return "none";
}

std::vector<std::pair<std::string, int>> index_enum_members(ClipStatus) {
  std::vector<std::pair<std::string, int>> out;
  for (auto s : {ClipStatus::parsed_new, ClipStatus::parsed_changed, ClipStatus::reused})
    out.emplace_back(clip_status_name(s), static_cast<int>(s));
  return out;
}

std::vector<std::pair<std::string, int>> index_enum_members(LabelSource) {
  std::vector<std::pair<std::string, int>> out;
  for (auto s :
       {LabelSource::none, LabelSource::file_name, LabelSource::sidecar, LabelSource::sidecar_cfg})
    out.emplace_back(label_source_name(s), static_cast<int>(s));
  return out;
}

}  // namespace mocap
