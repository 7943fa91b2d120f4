#pragma once
// What the mapping job's parts share: its account and progress through the caller's hooks,
// the default dictionary's notes among them, and the end of every job, scores.json.
#include <nlohmann/json.hpp>

#include <string>

#include "potmap/job/mapping_job.hpp"
#include "potmap/mapping/drive_mapper.hpp"

namespace potmap::job {

/// The hooks, each a no-op where the caller gave none.
struct Report {
  const MappingJobHooks& hooks;
  void note(const std::string& line) const {
    if (hooks.note) hooks.note(line);
  }
  void progress(const JobProgress& p) const {
    if (hooks.progress) hooks.progress(p);
  }
};

/// The dictionary of a job that transports: options.dictionary's file, else the built-in one of
/// dimension `dim` (hooks.default_dictionary, else its cached file). `where` receives the file.
Dictionary job_dictionary(const MappingJobOptions& options, const Report& report, int dim,
                          std::string* where);

/// The look-ahead's scores (all, beyond reach) into out.lookahead*, scores.json's "lookahead"
/// and "lookahead_ms_per_<unit>" (`ms` over `count` scans or keyframes), and the account's line.
void report_lookahead(const Scores& all, const Scores& beyond, double ms, std::size_t count,
                      const char* unit, const Report& report, nlohmann::json& j,
                      MappingJobResult& out);

/// The end of a job: `summary` gets the list of out.files with DIR/scores.json (which it is
/// written to, whole, and which is added to out.files); out.scores_json its text.
void write_scores(const std::string& dir, nlohmann::json summary, MappingJobResult& out);

}  // namespace potmap::job
