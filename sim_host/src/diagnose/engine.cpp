#include "engine.hpp"

namespace odoerr::sim::diag {

template class Engine<SyncDrive>;
template class Engine<DiffDrive>;
template class Engine<SyncDrive, Featured>;
template class Engine<DiffDrive, Featured>;

}  // namespace odoerr::sim::diag
