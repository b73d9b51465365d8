// `strata labels ...`: Mixture Graph encoding of segmentation (label) volumes (paper 4).
// Each action lives in its own file (cmd_labels_<action>.cpp).
#include "commands.hpp"

namespace strata::cli {

void register_labels_encode(CLI::App& labels, const GlobalOptions& global);
void register_labels_decode(CLI::App& labels, const GlobalOptions& global);
void register_labels_palette(CLI::App& labels, const GlobalOptions& global);
void register_labels_query(CLI::App& labels, const GlobalOptions& global);
void register_labels_calibrate(CLI::App& labels, const GlobalOptions& global);

void register_labels(CLI::App& app, const GlobalOptions& global) {
  CLI::App* labels = app.add_subcommand("labels", "Mixture Graph for label volumes: encode, decode, palette, query, calibrate");
  labels->require_subcommand(1);
  register_labels_encode(*labels, global);
  register_labels_decode(*labels, global);
  register_labels_palette(*labels, global);
  register_labels_query(*labels, global);
  register_labels_calibrate(*labels, global);
}

}  // namespace strata::cli
