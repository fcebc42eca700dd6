// One batch entry from one query's text (batch_entry.hpp).
#include "mocap/search/batch_entry.hpp"

#include <nlohmann/json.hpp>

#include "mocap/common/util/error.hpp"
#include "mocap/search/query.hpp"

namespace mocap {

BatchEntry parse_batch_entry(const std::string& text, const std::string& source, std::size_t line,
                             const std::filesystem::path& base_dir, const std::string& default_id) {
  BatchEntry e;
  e.id = default_id;
  e.line = line;
  try {
    e.query = parse_query_text(text, source, line, base_dir, default_id);
    e.id = e.query->id;
  } catch (const InputError& err) {
    // Keep the id when the text is valid JSON with one.
    try {
      const auto j = nlohmann::json::parse(text);
      if (j.is_object() && j.contains("id") && j["id"].is_string())
        e.id = j["id"].get<std::string>();
      if (j.is_object() && j.contains("id") && j["id"].is_number_integer())
        e.id = std::to_string(j["id"].get<long long>());
    } catch (const nlohmann::json::exception&) {
    }
    e.error = err.what();
    e.failure = err;
  }
  return e;
}

}  // namespace mocap
