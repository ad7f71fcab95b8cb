// odoerr tool: `odoerr map compile`, the map's tables as C++ source for the firmware's
// flash (sim_host/include/odoerr/sim/map_table.hpp).
#include <cstdio>
#include <memory>
#include <string>

#include "cli.hpp"
#include "commands.hpp"
#include "odoerr/sim/map_io.hpp"
#include "odoerr/sim/map_table.hpp"

namespace odoerr {

void registerMapCompileCommand(CLI::App& app, cli::Commands& cmds) {
  struct Opts {
    std::string map, out, symbol = "kOdoerrMap";
    double cell = -1;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* map = cli::family(app, "map", "maps: import, render, build from a log, compile for the firmware");
  CLI::App* sub = map->add_subcommand("compile", "write the map's walls and grid index as C++ constant tables (flash)");
  sub->add_option("MAP", o->map, "the map (.odomap, or an odolog's walls)")->required();
  sub->add_option("--out", o->out, "C++ source to write")->required();
  sub->add_option("--symbol", o->symbol, "name of the MapTables<float> it defines");
  sub->add_option("--cell", o->cell, "grid cell of the index (m); 0: no index; default: chosen from the map's size")
      ->check(CLI::Range(0.0, 100.0));
  cmds.add(sub, [o]() {
    std::vector<sim::OdologWall> walls;
    std::string err;
    sim::HostMap<float> hm;
    if (!sim::readMapWalls(o->map, &walls, &err) || !hm.build(walls, o->cell, &err)) {
      std::fprintf(stderr, "odoerr map compile: %s\n", err.c_str());
      return 1;
    }
    const std::string src = sim::mapTableSource(hm, o->symbol, "from " + o->map);
    if (!cli::writeFile(o->out, src, &err)) {
      std::fprintf(stderr, "odoerr map compile: %s\n", err.c_str());
      return 1;
    }
    const auto& g = hm.grid();
    std::fprintf(stderr, "odoerr map compile: %d walls, grid %d x %d (%g m cells), %zu index entries, %zu bytes; wrote %s\n",
                 hm.size(), g.nx, g.ny, g.nx > 0 ? double(g.cell) : 0.0, hm.cellItems().size(),
                 sim::mapTableBytes(hm), o->out.c_str());
    return 0;
  });
}

}  // namespace odoerr
