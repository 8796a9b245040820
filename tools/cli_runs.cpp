// The run store's subcommands (tools/cli_store.h for --db and run ids):
//
// imubench runs [--db PATH] [--json]
//   Lists the stored runs: id, state, start time (UTC), plan, IMU serial, exit reason.
// imubench export RUN --csv DIR [--results FILE.json] [--db PATH]
//   Writes run RUN (N or run:N) as an imubench-csv/1 recording directory; the store keeps the
//   doubles bit-exactly, so an imported recording exports to the same files. --results writes
//   the run's stored results (calibration coefficients, reports) as a JSON array.
// imubench import DIR [--plan-name NAME] [--serial S] [--db PATH]
//   Stores an imubench-csv/1 recording directory as a finished run (exit reason "imported")
//   and prints the new run id alone on stdout, for scripts: run=$(imubench import DIR).
//   --serial replaces the recording's IMU serial in the store.
// Registration only; the work is the store backend's (tools/cli_store.h): imubench-store runs
// it, imubench hands these commands to imubench-store.
#include <memory>
#include <string>

#include "tools/cli_common.h"
#include "tools/cli_store.h"

namespace imubench::tools {

void addStoreCommands(CLI::App& app) {
  {
    auto opt = std::make_shared<RunsOptions>();
    CLI::App* sub = app.add_subcommand("runs", "List the runs in the run store");
    addStoreOption(*sub, &opt->db);
    sub->add_flag("--json", opt->json, "Print the runs as a JSON array");
    sub->callback([opt] { runRuns(*opt); });
  }
  {
    auto opt = std::make_shared<ExportOptions>();
    CLI::App* sub =
        app.add_subcommand("export", "Write a stored run as an imubench-csv/1 recording");
    sub->add_option("run", opt->run, "Run id: N or run:N")->required();
    sub->add_option("--csv", opt->csv_dir, "Recording directory to write (created if missing)")
        ->required();
    sub->add_option("--results", opt->results,
                    "Also write the run's stored results to this JSON file");
    addStoreOption(*sub, &opt->db);
    sub->callback([opt] { runExport(*opt); });
  }
  {
    auto opt = std::make_shared<ImportOptions>();
    CLI::App* sub = app.add_subcommand(
        "import", "Store an imubench-csv/1 recording as a finished run; prints the run id");
    sub->add_option("dir", opt->dir, "Recording directory (imubench-csv/1)")->required();
    sub->add_option("--plan-name", opt->plan_name, "Plan name stored with the run");
    sub->add_option("--serial", opt->serial,
                    "IMU serial stored with the run (default: the recording's)");
    addStoreOption(*sub, &opt->db);
    sub->callback([opt] { runImport(*opt); });
  }
}

}  // namespace imubench::tools
