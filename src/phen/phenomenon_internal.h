/* phen/phenomenon_internal.h — how the scene builds its layers as sq_phenomenon handles. */
#ifndef SQ_PHENOMENON_INTERNAL_H
#define SQ_PHENOMENON_INTERNAL_H

#include "squall/phenomenon.h"

typedef enum sq__phen_stage {
    SQ__PHEN_OK = 0,
    SQ__PHEN_RULES = 1,  /* the parameter table's ranges or the phenomenon's validate refused */
    SQ__PHEN_MEMORY = 2, /* the memory limit refused */
    SQ__PHEN_CREATE = 3  /* create failed */
} sq__phen_stage;

typedef struct sq__phen_make {
    const sq_phen_plugin *plugin;
    const char *name;       /* instance name (copied) */
    const void *desc;       /* filled desc of plugin->desc_size bytes (copied, then resolved) */
    const sq_world *world;  /* borrowed for the handle's lifetime */
    bool validate_only;     /* resolve and check everything, create nothing */
    uint64_t memory_base;   /* bytes already committed by others (a scene's earlier layers) */
} sq__phen_make;

/* The one path from a desc to a handle (sq_phenomenon_create and the scene use it): resolve,
 * table ranges, the phenomenon's own validate, the memory check, create. *stage says which step
 * refused (the scene turns RULES messages into file:line + layers.<name>.<key>). */
sq_result sq__phenomenon_make(sq_context *ctx, const sq__phen_make *m, sq_phenomenon **out,
                              sq__phen_stage *stage);

/* Creates the phenomenon of a handle made with validate_only (SQ__PHEN_CREATE stage). */
sq_result sq__phenomenon_instantiate(sq_phenomenon *p);

/* Checkpoints: the handle's clock and the plug-in's records (save_state / load_state hooks);
 * SQ_ERR_UNSUPPORTED, naming the layer, when the phenomenon has none. */
sq_result sq__phenomenon_save_state(const sq_phenomenon *p, sq_state_writer *w);
sq_result sq__phenomenon_load_state(sq_phenomenon *p, sq_state_reader *r);

#endif
