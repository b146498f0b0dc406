/* commands.h — the `vis` commands (one file each) and the table main.c dispatches through. */
#ifndef VIS_CLI_COMMANDS_H
#define VIS_CLI_COMMANDS_H

#include "args.h"

int cmd_cull(const cli_args *args);
int cmd_info(const cli_args *args);
int cmd_export(const cli_args *args);
int cmd_run(const cli_args *args);
int cmd_bench(const cli_args *args);
int cmd_accuracy(const cli_args *args);
/* `vis query` parses its own options (argv[0] is "query"). */
int cmd_query(int argc, char **argv);

extern const cli_command cli_commands[];
extern const size_t cli_command_count;

#endif
