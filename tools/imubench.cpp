// imubench: the command line. Subcommands register themselves from their own files (see the
// pattern in tools/cli_common.h); main only wires them and maps failures to exit codes:
//   0 success, 1 the command failed (bad input file, plan errors, failed work),
//   2 bad command line (CLI11 parse error).
// The same main is linked twice (tools/CMakeLists.txt): `imubench-cli` without the run store, which
// hands the store commands to `imubench-store` (NeedsRunStore, tools/cli_store.h), and
// `imubench-store` with it.
#include <exception>
#include <iostream>
#include <string>

#include "imubench_build_id.h"
#include "tools/cli11.h"
#include "tools/cli_common.h"
#include "tools/cli_store.h"

int main(int argc, char** argv) {
  using namespace imubench::tools;
  CLI::App app{"imubench: IMU calibration test-bench controller"};
  app.set_version_flag("--version", IMUBENCH_BUILD_ID);
  app.require_subcommand(1);
  app.fallthrough(false);
  addRunCommand(app);
  addSimulateCommand(app);
  addPlanCommand(app);
  addObserveCommand(app);  // `plan observe`: after addPlanCommand
  addNavCommand(app);
  addCalibrateCommand(app);
  addExplainCommand(app);
  addExperimentCommand(app);
  addStoreCommands(app);
  addControlCommands(app);
  addResultsCommand(app);
  addThermalCommand(app);
  addApplyCommand(app);
  addImportCsvCommand(app);
  addExportCoeffsCommand(app);
  addCertificateCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);  // prints the message
    return 2;
  } catch (const NeedsRunStore&) {
    // Nothing has been printed yet: the store program redoes the command from the start.
    // runStoreProgram returns only when it could not run it (its output would come first).
    const std::string why = runStoreProgram(argv);
    std::cerr << "imubench: " << why << "\n";
    return 1;
  } catch (const CommandFailed& e) {
    std::cerr << "imubench: " << e.what() << "\n";
    return e.exitCode();
  } catch (const std::exception& e) {
    std::cerr << "imubench: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
