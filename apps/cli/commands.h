/* commands.h — the sub-commands of `squall`. Each takes argv with argv[0] = command name. */
#ifndef SQ_CLI_COMMANDS_H
#define SQ_CLI_COMMANDS_H

int sq_cmd_render(int argc, char **argv);   /* render and simulate */
int sq_cmd_info(int argc, char **argv);
int sq_cmd_scenes(int argc, char **argv);
int sq_cmd_scene(int argc, char **argv);
int sq_cmd_params(int argc, char **argv);
int sq_cmd_bench(int argc, char **argv);
int sq_cmd_validate(int argc, char **argv);
int sq_cmd_visibility(int argc, char **argv);
int sq_cmd_wrf(int argc, char **argv);

#endif
