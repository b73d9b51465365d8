// The Mixture Graph bitstream (section "mixture_graph": header, node triples, codebook), read as
// EncodedLabels reads it, then scheduled and, for small graphs, turned into the lookup tables
// every label decoder and query uses.
#include "support.hpp"
#include "strata/mixture/graph_bitstream.hpp"
#include "strata/mixture/lookup.hpp"
#include "strata/mixture/schedule.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  strata::fuzz::run_guarded([&] {
    strata::mixture::GraphHeader header;
    const auto graph = strata::mixture::read_graph_bitstream(strata::fuzz::as_bytes(data, size), "fuzz", &header);
    const auto schedule = strata::mixture::make_schedule(graph);
    if (graph.node_count() <= 4096) (void)strata::mixture::MixtureLookup::build(graph, schedule);
  });
  return 0;
}
