// odoerr tool: `odoerr map import | render | grid-from-carmen`, the map tool chain written
// in Python (tools/map/odoerr_map.py; docs/map-format.md). This file only declares the
// options (so that --help and argument errors come from the tool) and hands them over.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cli.hpp"
#include "commands.hpp"

namespace odoerr {

namespace {

std::string mapScript() { return cli::scriptPath("ODOERR_MAP_SCRIPT", ODOERR_MAP_SCRIPT); }

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

void registerMapCommands(CLI::App& app, cli::Commands& cmds) {
  CLI::App* map = cli::family(app, "map", "maps: import, render, build from a log, compile for the firmware");

  struct ImportOpts {
    std::string map, out, png, method = "skeleton";
    bool faces = false;
  };
  auto im = std::make_shared<ImportOpts>();
  CLI::App* imp = map->add_subcommand("import", "ROS map_server map (YAML + PGM) -> line map (.odomap), with its fit");
  imp->add_option("MAP", im->map, "the map's YAML file")->required();
  imp->add_option("--out", im->out, ".odomap file to write")->required();
  imp->add_option("--png", im->png, "also draw the segments over the grid (PNG)");
  imp->add_option("--method", im->method, "extraction: skeleton (default) or ransac")
      ->check(CLI::IsMember({"skeleton", "ransac"}));
  imp->add_flag("--faces", im->faces,
                "put each segment on its band's free-facing side (where the laser's returns are), not its middle");
  cmds.add(imp, [im]() {
    std::vector<std::string> a{"import", im->map, "--out", im->out, "--method", im->method};
    if (!im->png.empty()) a.insert(a.end(), {"--png", im->png});
    if (im->faces) a.push_back("--faces");
    return cli::runPython(mapScript(), a);
  });

  struct RenderOpts {
    std::string map, grid, out;
  };
  auto ro = std::make_shared<RenderOpts>();
  CLI::App* ren = map->add_subcommand("render", "draw a map's segments (over its grid) as a PNG");
  ren->add_option("MAP", ro->map, "the map (.odomap, or an odolog's walls)")->required();
  ren->add_option("--grid", ro->grid, "the occupancy grid's YAML file to draw under it");
  ren->add_option("--out", ro->out, "PNG to write")->required();
  cmds.add(ren, [ro]() {
    std::vector<std::string> a{"render", ro->map, "--out", ro->out};
    if (!ro->grid.empty()) a.insert(a.end(), {"--grid", ro->grid});
    return cli::runPython(mapScript(), a);
  });

  struct GridOpts {
    std::string log, out;
    double resolution = 0.05, max_range = 20.0, no_return = 0.0, beam_step = 0.0;
    int max_scans = 0;
  };
  auto go = std::make_shared<GridOpts>();
  CLI::App* grd = map->add_subcommand("grid-from-carmen",
                                      "occupancy grid (PGM + YAML, as map_saver writes) from a corrected CARMEN log");
  grd->add_option("LOG", go->log, "CARMEN log (.log or .log.gz) with corrected FLASER poses")->required();
  grd->add_option("--out", go->out, "writes PREFIX.pgm and PREFIX.yaml")->required();
  grd->add_option("--resolution", go->resolution, "cell size (m), default 0.05")->check(CLI::Range(1e-3, 10.0));
  grd->add_option("--max-range", go->max_range, "usable laser range (m), default 20")->check(CLI::Range(0.1, 80.0));
  grd->add_option("--max-scans", go->max_scans, "only the first N scans (default: all)")->check(CLI::PositiveNumber);
  // The laser as the importer reads it (beam count, PARAM lines; docs/real-data.md); these override.
  CLI::Option* no_ret = grd->add_option("--no-return", go->no_return,
                                        "readings >= M (m) are no return and not used; default PARAM "
                                        "robot_front_laser_max, else 80 (as odoerr import carmen)")
                            ->check(CLI::PositiveNumber);
  CLI::Option* step = grd->add_option("--beam-step", go->beam_step,
                                      "override the angle between beams (deg); default the log's (beam count, PARAM)")
                          ->check(CLI::Range(0.01, 10.0));
  cmds.add(grd, [go, no_ret, step]() {
    std::vector<std::string> a{"grid-from-carmen", go->log, "--out", go->out, "--resolution", num(go->resolution),
                               "--max-range", num(go->max_range)};
    if (go->max_scans > 0) a.insert(a.end(), {"--max-scans", std::to_string(go->max_scans)});
    if (no_ret->count() > 0) a.insert(a.end(), {"--no-return", num(go->no_return)});
    if (step->count() > 0) a.insert(a.end(), {"--beam-step", num(go->beam_step)});
    return cli::runPython(mapScript(), a);
  });
}

}  // namespace odoerr
