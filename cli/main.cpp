#include <fmt/format.h>

#include <clocale>
#include <map>

#include "commands.h"
#include "solid/formats/version.h"
#include "exit_codes.h"
#include "signals.h"

int main(int argc, char** argv) {
  // Numbers in every file we read and write use the C locale, whatever the user's is.
  std::setlocale(LC_ALL, "C");
  solid::cli::SetCommandLine(argc, argv);
  CLI::App app{"solid: label-free synthetic pretraining data for object detectors.\n"
               "Run 'solid COMMAND --help' for the flags of a command."};
  app.set_version_flag("--version", fmt::format("solid {} (commit {})", solid::Version(), solid::BuildCommit()));
  app.require_subcommand(1);
  std::map<CLI::App*, solid::cli::Command> commands;
  for (auto add : {solid::cli::AddConvert, solid::cli::AddSample, solid::cli::AddOptimize, solid::cli::AddRender,
                    solid::cli::AddMetrics, solid::cli::AddExport, solid::cli::AddReport, solid::cli::AddInspect,
                    solid::cli::AddValidate, solid::cli::AddIndex}) {
    solid::cli::Command run = add(app);
    commands[app.get_subcommands({}).back()] = std::move(run);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return solid::cli::kExitUsage;
  }
  for (CLI::App* sub : app.get_subcommands()) return commands.at(sub)();
  return solid::cli::kExitUsage;
}
