// dco-diag: a report of a dcod LCM log (what lcm-logger recorded in the field): a text summary
// on stdout, a self-contained HTML report, optionally the key numbers as JSON.

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/format.h>

#include "dco/core/error.hpp"
#include "dco/core/file_replace.hpp"
#include "dco/diag/html_report.hpp"
#include "dco/diag/log_digest.hpp"
#include "dco/diag/log_summary.hpp"
#include "dco/tools/command_line.hpp"

namespace {

constexpr const char* kUsage =
    R"(usage: dco-diag LOG [--html FILE | --no-html] [--json FILE] [--previews N]

Reads an LCM log of dcod's channels (lcm-logger) to its end, past damaged stretches, and
prints a summary. --html: the report's path (default LOG.html); --json: the key numbers as
JSON ("-" = stdout instead of the summary); --previews: depth thumbnails in the report
(default 48). Exit status 0 with a report, also for a damaged log (the summary says how far
it read); 1 when the file is not an LCM log; 2 for a usage mistake.
)";

// Written beside its name and renamed over it: a failed write leaves the last report whole.
void write_file(const std::filesystem::path& path, const std::string& text) {
  dco::replace_file(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw dco::Error("cannot write " + path.string() + ": " + std::strerror(errno));
    out << text;
    out.close();
    if (!out) throw dco::Error("cannot write " + path.string() + ": " + std::strerror(errno));
  });
}

// A report written over the recording it reads would lose the field log.
void refuse_the_log(const std::string& log, const std::string& report, const char* option) {
  if (dco::tools::same_file(log, report))
    throw dco::tools::UsageError(fmt::format("{} {} is the log itself", option, report));
}

}  // namespace

int main(int argc, char** argv) {
  return dco::tools::run_tool("dco-diag", [&] {
    using dco::tools::UsageError;
    std::string log, html, json;
    bool no_html = false;
    dco::diag::DigestOptions options;
    dco::tools::ArgCursor args(argc, argv);
    while (args.next()) {
      const std::string_view name = args.name();
      if (name == "--help" || name == "-h") {
        std::fputs(kUsage, stdout);
        return 0;
      } else if (name == "--html") {
        html = args.value();
        if (html.empty()) throw UsageError("--html needs a file name");
      } else if (name == "--no-html") {
        no_html = args.flag();
      } else if (name == "--json") {
        json = args.value();
        if (json.empty()) throw UsageError("--json needs a file name (or - for stdout)");
      } else if (name == "--previews") {
        const int n = args.int_value();
        if (n < 0 || n > 10000) throw UsageError("--previews must be 0 to 10000");
        options.max_previews = static_cast<std::size_t>(n);
      } else if (!name.starts_with("-") && log.empty()) {
        log = std::string(name);
      } else {
        throw UsageError(fmt::format("unexpected argument {}", name));
      }
    }
    if (log.empty()) throw UsageError("no log given");
    if (no_html && !html.empty()) throw UsageError("--html and --no-html exclude each other");
    if (!no_html && html.empty()) html = log + ".html";
    if (!no_html) refuse_the_log(log, html, "--html");
    if (!json.empty() && json != "-") refuse_the_log(log, json, "--json");
    if (!no_html && !json.empty() && json != "-" && dco::tools::same_file(html, json))
      throw UsageError(fmt::format("--html and --json name one file, {}", json));

    const dco::diag::LogDigest digest = dco::diag::digest_log(log, options);
    const dco::diag::LogSummary summary = dco::diag::summarize(digest);
    // The summary goes out whatever becomes of the files: a log on read-only media still has
    // its summary, then the error.
    std::string failed;
    const auto write_or_note = [&](const std::string& path, const std::string& text) {
      try {
        write_file(path, text);
        return true;
      } catch (const dco::Error& e) {
        if (failed.empty()) failed = e.what();
        return false;
      }
    };
    const bool html_written =
        !no_html && write_or_note(html, dco::diag::html_report(digest, summary));
    if (json == "-") {
      std::fputs(dco::diag::json_summary(digest, summary).c_str(), stdout);
    } else {
      if (!json.empty()) write_or_note(json, dco::diag::json_summary(digest, summary));
      std::fputs(dco::diag::text_summary(digest, summary, html_written ? html : "").c_str(),
                 stdout);
    }
    std::fflush(stdout);
    if (!failed.empty()) throw dco::Error(failed);
    return 0;
  });
}
