#pragma once
// Character: the body a query's energy is measured for.
//
// A character is a total mass, a sex (which de Leva table) and optional
// overrides per segment class or per joint name; build_body (body.hpp) turns
// it into masses and inertias on a skeleton. Character files are JSON
// (schema: docs/character.md); reading one validates every field and throws
// InputError naming the file and the field. Nothing here looks at a skeleton:
// joint names in a character are resolved later (find_joint_by_alias), and a
// name no joint matches is not an error here.
#include <filesystem>
#include <map>
#include <string>

#include "mocap/common/body/segment_class.hpp"

namespace mocap {

enum class Sex { male, female };

/// Everything of a character that its Body depends on: two characters with
/// equal settings get the same masses, inertias and energies whatever their
/// names. Masses in kilograms; scales are factors (> 0 when read from a file).
struct BodySettings {
  /// Total body mass the table fractions multiply, kg.
  double total_mass_kg = 70.0;
  /// Which de Leva table (male or female).
  Sex sex = Sex::male;
  /// Absolute mass override per class (kg, both sides each get this value).
  std::map<SegmentClass, double> class_mass_kg;
  /// Multiplier on the table mass per class (applied after total-mass scaling).
  std::map<SegmentClass, double> class_mass_scale;
  /// Absolute mass override per joint name (kg); wins over class settings.
  std::map<std::string, double> joint_mass_kg;
  /// Length scale per class / per joint name: scales the bones the segment
  /// owns (its children's offsets and its End Site). Joint wins over class.
  std::map<SegmentClass, double> class_length_scale;
  std::map<std::string, double> joint_length_scale;

  bool operator==(const BodySettings&) const = default;
};

/// A target character (what the query's body is). JSON schema: docs/character.md.
/// The default is the 70 kg male without overrides.
struct Character : BodySettings {
  /// Shown in outputs; never changes the body.
  std::string name = "default";

  bool operator==(const Character&) const = default;
};

/// Parses and validates a character JSON text (version 1; every key optional).
/// Throws InputError(source, 0, "<field>: <what was expected>") for invalid
/// JSON, an unknown key or class, a non-positive or non-finite number, both
/// mass_kg and mass_scale on one class, or an unsupported version.
Character parse_character_json(const std::string& text, const std::string& source);
/// parse_character_json of a file's contents; an unreadable file throws
/// InputError(path, 0, ...).
Character read_character_file(const std::filesystem::path& path);

}  // namespace mocap
