// `strata formats [--json | --markdown]`: the registered volume formats and what each can do,
// from the registry (io/formats.hpp). --markdown prints the README's format table, which a test
// compares with README.md so the table cannot go stale.
#include <cstdio>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "strata/io/formats.hpp"

namespace strata::cli {

namespace {

struct FormatsArgs {
  bool json = false, markdown = false;
};

std::string joined(const std::vector<std::string>& items, const std::string& separator) {
  std::string text;
  for (const std::string& item : items) text += (text.empty() ? "" : separator) + item;
  return text;
}

// "all dtypes", "all but i8", or the list: what a reader returns or a writer stores.
std::string dtypes_text(io::DTypeSet set) {
  const io::DTypeSet all = io::DTypeSet::all();
  if (set == all) return "all dtypes";
  std::vector<std::string> names, missing;
  for (DType t : all.list()) (set.contains(t) ? names : missing).emplace_back(dtype_name(t));
  if (names.empty()) return "none";
  if (missing.size() <= 2) return "all but " + joined(missing, ", ");
  return joined(names, ", ");
}

nlohmann::json dtype_names(io::DTypeSet set) {
  nlohmann::json names = nlohmann::json::array();
  for (DType t : set.list()) names.push_back(std::string(dtype_name(t)));
  return names;
}

// The capabilities as words ("streaming, several volumes, spacing").
std::vector<std::string> capability_words(const io::VolumeFormat& f) {
  std::vector<std::string> words;
  if (f.capabilities.streaming) words.emplace_back("streaming");
  if (f.capabilities.multi_volume) words.emplace_back("several volumes");
  if (f.capabilities.spatial_metadata) words.emplace_back("spacing");
  if (f.sniff) words.emplace_back("detected by content");
  return words;
}

// What a reader or writer column says: the sample types, then the format's notes.
std::string column(io::DTypeSet dtypes, const std::string& notes) {
  return dtypes_text(dtypes) + (notes.empty() ? "" : "; " + notes);
}

std::string markdown_extensions(const io::VolumeFormat& f) {
  std::vector<std::string> quoted;
  for (const std::string& ext : f.extensions) quoted.push_back("`" + ext + "`");
  std::string text = joined(quoted, ", ");
  if (!f.directory.empty()) text += (text.empty() ? "" : " or ") + f.directory;
  return text;
}

void print_markdown() {
  std::printf("| format | extensions | read | write | capabilities |\n| --- | --- | --- | --- | --- |\n");
  for (const io::VolumeFormat* f : io::formats()) {
    const std::string write = f->create_writer ? column(f->write_dtypes, f->write_notes) : "no writer";
    std::printf("| %s | %s | %s | %s | %s |\n", f->title.c_str(), markdown_extensions(*f).c_str(),
                column(f->read_dtypes, f->read_notes).c_str(), write.c_str(),
                joined(capability_words(*f), ", ").c_str());
  }
}

nlohmann::json format_json(const io::VolumeFormat& f) {
  nlohmann::json j{{"name", f.name},
                   {"title", f.title},
                   {"description", f.description},
                   {"extensions", f.extensions},
                   {"directory", f.directory.empty() ? nlohmann::json() : nlohmann::json(f.directory)},
                   {"detected_by_content", bool(f.sniff)},
                   {"streaming", f.capabilities.streaming},
                   {"multi_volume", f.capabilities.multi_volume},
                   {"spatial_metadata", f.capabilities.spatial_metadata},
                   {"read", {{"dtypes", dtype_names(f.read_dtypes)}, {"notes", f.read_notes}}}};
  j["write"] = f.create_writer ? nlohmann::json{{"dtypes", dtype_names(f.write_dtypes)},
                                                {"label_dtypes", dtype_names(f.label_dtypes())},
                                                {"notes", f.write_notes}}
                               : nlohmann::json();
  return j;
}

void print_text() {
  for (const io::VolumeFormat* f : io::formats()) {
    std::vector<std::string> names = f->extensions;
    if (!f->directory.empty()) names.push_back(f->directory);
    std::printf("%-8s %s\n", f->name.c_str(), joined(names, ", ").c_str());
    std::printf("%-8s %s\n", "", f->description.c_str());
    std::vector<std::string> labels;
    for (DType t : f->label_dtypes().list()) labels.emplace_back(dtype_name(t));
    const std::string write =
        f->create_writer ? dtypes_text(f->write_dtypes) + " (labels: " + joined(labels, ", ") + ")" : "no";
    std::printf("%-8s read: %s; write: %s\n", "", dtypes_text(f->read_dtypes).c_str(), write.c_str());
    std::printf("%-8s %s\n", "", joined(capability_words(*f), ", ").c_str());
  }
}

void run_formats(const FormatsArgs& args) {
  if (args.json) {
    nlohmann::json all = nlohmann::json::array();
    for (const io::VolumeFormat* f : io::formats()) all.push_back(format_json(*f));
    std::printf("%s\n", nlohmann::json{{"formats", all}}.dump(2).c_str());
  } else if (args.markdown) {
    print_markdown();
  } else {
    print_text();
  }
}

}  // namespace

void register_formats(CLI::App& app, const GlobalOptions&) {
  auto args = std::make_shared<FormatsArgs>();
  CLI::App* cmd = app.add_subcommand("formats", "List the volume formats: extensions, sample types, capabilities");
  CLI::Option* json = cmd->add_flag("--json", args->json, "Print JSON (for scripts)");
  cmd->add_flag("--markdown", args->markdown, "Print the README's table of formats")->excludes(json);
  cmd->callback([args] { run_formats(*args); });
}

}  // namespace strata::cli
