// Character files: parsing and validating the JSON form of a Character
// (docs/character.md). Every error is an InputError naming the source and the
// dotted field path ("segments.upper_arm.mass_kg").
#include "mocap/common/body/character.hpp"
#include "mocap/common/util/json_text.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <vector>

#include "mocap/common/util/error.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/common/util/input_limits.hpp"

namespace mocap {

namespace {

using nlohmann::json;

std::string dotted(const std::vector<std::string>& path) {
  std::string s;
  for (const std::string& p : path) {
    if (!s.empty()) s += '.';
    s += p;
  }
  return s;
}

std::string all_class_names() {
  std::string s;
  for (SegmentClass c : kMassiveClasses) {
    if (!s.empty()) s += ", ";
    s += segment_class_name(c);
  }
  return s;
}

struct JsonReader {
  const std::string& source;

  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw InputError(source, 0, (field.empty() ? std::string() : field + ": ") + what);
  }
  const json& object(const json& v, const std::string& field) const {
    if (!v.is_object()) fail(field, "expected an object, got " + std::string(v.type_name()));
    return v;
  }
  // A positive finite number up to `max` (docs/cli.md "Value ranges":
  // 10,000 kg for masses, 100 for scale factors).
  double positive(const json& v, const std::string& field, const char* unit) const {
    if (!v.is_number())
      fail(field, std::string("expected a positive number (") + unit + "), got " + v.type_name());
    const double x = v.get<double>();
    if (!std::isfinite(x) || !(x > 0.0))
      fail(field,
           std::string("expected a positive finite number (") + unit + "), got " + json_text(v));
    const double max = std::string(unit) == "kg" ? 1e4 : 100.0;
    if (x > max)
      fail(field, std::string("out of range: ") + json_text(v) + " " + unit + "; at most " +
                      json_text(json(max)));
    return x;
  }
  void unknown_key(const std::string& field, const std::string& expected) const {
    fail(field, "unknown key; expected " + expected);
  }
};

}  // namespace

Character parse_character_json(const std::string& text, const std::string& source) {
  const JsonReader r{source};
  // The callback tracks the key path so that a number overflow ("1e999") can
  // still be reported against its field.
  std::vector<std::string> path;
  json doc;
  try {
    doc = json::parse(text, [&path](int depth, json::parse_event_t ev, json& parsed) {
      if (ev == json::parse_event_t::key && depth > 0) {
        path.resize(static_cast<std::size_t>(depth));
        path.back() = parsed.get<std::string>();
      }
      return true;
    });
  } catch (const json::parse_error& e) {
    r.fail("", "invalid JSON at byte " + std::to_string(e.byte) + ": " + e.what());
  } catch (const json::exception& e) {
    r.fail(dotted(path), std::string("invalid number: ") + e.what());
  }
  r.object(doc, "<document>");
  Character ch;
  for (const auto& [key, value] : doc.items()) {
    if (key == "version") {
      if (!value.is_number_integer() || value.get<long long>() != 1)
        r.fail(key, "unsupported version " + json_text(value) + " (this program reads version 1)");
    } else if (key == "name") {
      if (!value.is_string() || value.get<std::string>().empty())
        r.fail(key, "expected a non-empty string, got " + json_text(value));
      ch.name = value.get<std::string>();
    } else if (key == "total_mass_kg") {
      ch.total_mass_kg = r.positive(value, key, "kg");
    } else if (key == "sex") {
      const std::string s = value.is_string() ? value.get<std::string>() : std::string();
      if (s == "male")
        ch.sex = Sex::male;
      else if (s == "female")
        ch.sex = Sex::female;
      else
        r.fail(key, "expected \"male\" or \"female\", got " + json_text(value));
    } else if (key == "segments") {
      r.object(value, key);
      for (const auto& [cname, entry] : value.items()) {
        const std::string field = "segments." + cname;
        const std::optional<SegmentClass> cls = parse_segment_class(cname);
        if (!cls || *cls == SegmentClass::none)
          r.fail(field, "unknown segment class; expected one of " + all_class_names());
        r.object(entry, field);
        if (entry.contains("mass_kg") && entry.contains("mass_scale"))
          r.fail(field, "give mass_kg or mass_scale, not both");
        for (const auto& [k, v] : entry.items()) {
          const std::string f = field + "." + k;
          if (k == "mass_kg")
            ch.class_mass_kg[*cls] = r.positive(v, f, "kg");
          else if (k == "mass_scale")
            ch.class_mass_scale[*cls] = r.positive(v, f, "factor");
          else if (k == "length_scale")
            ch.class_length_scale[*cls] = r.positive(v, f, "factor");
          else
            r.unknown_key(f, "mass_kg, mass_scale or length_scale");
        }
      }
    } else if (key == "joints") {
      r.object(value, key);
      for (const auto& [jname, entry] : value.items()) {
        const std::string field = "joints." + jname;
        if (jname.empty()) r.fail("joints", "empty joint name");
        r.object(entry, field);
        for (const auto& [k, v] : entry.items()) {
          const std::string f = field + "." + k;
          if (k == "mass_kg")
            ch.joint_mass_kg[jname] = r.positive(v, f, "kg");
          else if (k == "length_scale")
            ch.joint_length_scale[jname] = r.positive(v, f, "factor");
          else
            r.unknown_key(f, "mass_kg or length_scale");
        }
      }
    } else {
      r.unknown_key(key, "version, name, total_mass_kg, sex, segments or joints");
    }
  }
  return ch;
}

Character read_character_file(const std::filesystem::path& path) {
  const FileBytes text = read_input_file(path, input_limits().json_file_bytes);
  return parse_character_json(std::string(text.view()), path.string());
}

}  // namespace mocap
