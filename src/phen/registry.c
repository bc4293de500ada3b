/* registry.c — the phenomenon plug-ins compiled into this build: one line each. */
#include <string.h>

#include "sq_config.h"
#include "squall/plugin.h"

#if SQ_HAVE_SANDSTORM
extern const sq_phen_plugin sq__sandstorm_plugin;
#endif
#if SQ_HAVE_SNOWDRIFT
extern const sq_phen_plugin sq__snowdrift_plugin;
#endif
#if SQ_HAVE_AVALANCHE
extern const sq_phen_plugin sq__avalanche_plugin;
#endif
#if SQ_HAVE_CLOUDS
extern const sq_phen_plugin sq__clouds_plugin;
#endif
#if SQ_HAVE_SNOWCOVER
extern const sq_phen_plugin sq__snowcover_plugin;
#endif

static const sq_phen_plugin *const plugins[] = {
#if SQ_HAVE_SANDSTORM
    &sq__sandstorm_plugin,
#endif
#if SQ_HAVE_SNOWDRIFT
    &sq__snowdrift_plugin,
#endif
#if SQ_HAVE_AVALANCHE
    &sq__avalanche_plugin,
#endif
#if SQ_HAVE_CLOUDS
    &sq__clouds_plugin,
#endif
#if SQ_HAVE_SNOWCOVER
    &sq__snowcover_plugin,
#endif
    NULL};

int sq_plugin_count(void) { return (int)(sizeof plugins / sizeof plugins[0]) - 1; }

const sq_phen_plugin *sq_plugin_at(int i)
{
    return i >= 0 && i < sq_plugin_count() ? plugins[i] : NULL;
}

const sq_phen_plugin *sq_plugin_find(const char *name)
{
    for (int i = 0; i < sq_plugin_count(); i++)
        if (name && strcmp(plugins[i]->name, name) == 0) return plugins[i];
    return NULL;
}
