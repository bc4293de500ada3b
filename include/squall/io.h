/* squall/io.h — files: safe output (temporary name + rename), PNG, MP4 (H.264 through FFmpeg's
 * libraries), NetCDF (CF conventions) and VTK image data, 16-bit heightmaps. Inputs are never
 * written. Every reader treats its input as untrusted and names the file and place on error. */
#ifndef SQ_IO_H
#define SQ_IO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/drawable.h"
#include "squall/mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- safe outputs -------------------------------------------------------------------------- */
/* Checks that path can be created: its directory exists and is writable, and the file does not
 * exist unless overwrite. Fails with SQ_ERR_IO (missing directory, named) or SQ_ERR_EXISTS. */
SQ_API sq_result sq_output_check(const char *path, bool overwrite);
/* Whether two output paths name the same file: the same existing file (symlinks followed, hard
 * links included), or, when one does not exist yet, the same name in the same directory
 * ("out/m.csv", "./out/m.csv" and "out/../out/m.csv" are one name). Two outputs of one run must
 * not be the same file: the later would silently replace the earlier. */
SQ_API bool sq_output_same_file(const char *a, const char *b);
/* Builds the temporary-name prefix for path ("dir/.name.tmp-PID") into buf; the writers append
 * "-N", the first N whose file can be created exclusively. */
SQ_API sq_result sq_output_temp_name(const char *path, char *buf, size_t size);
/* Flushes tmp to disk and renames it to path (atomic on one filesystem); refuses to replace an
 * existing path unless overwrite (SQ_ERR_EXISTS). On failure tmp is left for the caller. */
SQ_API sq_result sq_output_commit(const char *tmp, const char *path, bool overwrite);
/* Inputs are never written: refuses (SQ_ERR_INVALID_ARG, naming the output and the input) an
 * output path that resolves, symlinks followed, to a file ctx has read (the scene file,
 * heightmap, DEM, mesh, WRF file: sq_context_input_count). With prefix, the numbered outputs
 * of a series are checked: every existing entry whose name starts with the path's last part and
 * ends in five or more digits and an extension ("out/frames/frame_" covers frame_00012.png).
 * Call it for every output before any work; --overwrite does not change the answer. */
SQ_API sq_result sq_output_check_inputs(sq_context *ctx, const char *path, bool prefix);
/* Removes the temporaries ".NAME.tmp-PID-N" that a run killed by SIGKILL (or a crash) left next
 * to path (with prefix: next to every name starting with the path's last part), if process
 * PID is gone; each removal is logged as a warning. Returns how many were removed. */
SQ_API int sq_output_remove_stale(sq_context *ctx, const char *path, bool prefix);
/* Writes bytes to path through a temporary file (removed on any failure). */
SQ_API sq_result sq_output_write_file(const char *path, const void *data, size_t size,
                                      bool overwrite);

/* Checks a directory for a series of outputs (PNG frames): it is created when missing (its parent
 * must exist; *created then tells the caller it may remove it on failure), and first_file (a name
 * inside it, may be NULL) must not exist unless overwrite. SQ_ERR_IO names the directory. */
SQ_API sq_result sq_output_check_dir(const char *dir, const char *first_file, bool overwrite,
                                     bool *created);

/* ---- PNG ----------------------------------------------------------------------------------- */
SQ_API sq_result sq_png_write_rgba8(const char *path, int width, int height,
                                    const uint8_t *rgba, bool overwrite);
/* 16-bit grey PNG (for depth maps): values 0..65535. */
SQ_API sq_result sq_png_write_gray16(const char *path, int width, int height,
                                     const uint16_t *gray, bool overwrite);
/* Reads any PNG as 8-bit RGBA (palette, grey and 16-bit are converted; alpha 255 where the file
 * has none), rows top first. Free with sq_free(ctx, *rgba_out). */
SQ_API sq_result sq_png_read_rgba8(sq_context *ctx, const char *path, uint8_t **rgba_out,
                                   int *width, int *height);
/* Reads a 16-bit greyscale heightmap (rows top first, native-endian values 0..65535); refuses
 * other bit depths/colour types (SQ_ERR_INVALID_ARG), images larger than max_pixels
 * (SQ_ERR_TOO_LARGE; max_pixels <= 0 -> 16384*16384), corrupt or truncated files
 * (SQ_ERR_PARSE), naming the file, what it found and the rule. Free with sq_free(ctx, *out). */
SQ_API sq_result sq_png_read_heightmap16(sq_context *ctx, const char *path, int max_pixels,
                                         uint16_t **out, int *width, int *height);

/* ---- MP4 video ------------------------------------------------------------------------------- */
typedef struct sq_video_desc {
    const char *path;   /* final name; written to a temporary name until closed */
    int width, height;  /* even numbers for yuv420p; odd sizes are refused with a message */
    int fps;            /* 0 -> 30 */
    int crf;            /* x264 quality 0..51; 0 -> 20 */
    bool overwrite;
} sq_video_desc;

typedef struct sq_video_writer sq_video_writer;

/* Opens an H.264 MP4 writer (FFmpeg's libraries) under the output rules above: frames go to a
 * temporary file renamed by sq_video_close. SQ_ERR_UNSUPPORTED without MP4 support;
 * SQ_ERR_INVALID_ARG for odd sizes or a bad fps/crf; SQ_ERR_EXISTS without overwrite. */
SQ_API sq_result sq_video_open(sq_context *ctx, const sq_video_desc *desc, sq_video_writer **out);
/* Adds one frame: 8-bit RGBA, top row first. */
SQ_API sq_result sq_video_add_rgba8(sq_video_writer *w, const uint8_t *rgba);
/* Finishes the file and renames it to its final name. */
SQ_API sq_result sq_video_close(sq_video_writer *w);
/* Abandons the file: removes the temporary, the final name is untouched. Accepts NULL. */
SQ_API void sq_video_abort(sq_video_writer *w);

typedef struct sq_video_info {
    int width, height;
    int frames;         /* decoded frame count */
    double fps;
    char codec[32];     /* e.g. "h264" */
    char pix_fmt[32];   /* e.g. "yuv420p" */
    double mean_luma;   /* mean Y of all decoded frames (0..255), for tests */
} sq_video_info;

/* Decodes every frame of a video file (for tests and `squall info FILE`). */
SQ_API sq_result sq_video_probe(sq_context *ctx, const char *path, sq_video_info *out);

/* ---- NetCDF (CF-1.8) and VTK image data ----------------------------------------------------- */
typedef struct sq_field_file_desc {
    const char *path;
    const char *title;        /* global attribute */
    const char *source;       /* e.g. "squall 0.1.0 sandstorm" */
    double time_s;            /* value of the time coordinate: seconds since the clock's start */
    bool overwrite;
    /* Date and time of the clock's start for CF time units "seconds since <reference_time>",
     * as "YYYY-MM-DD" or "YYYY-MM-DD hh:mm:ss" (UTC). NULL -> "2000-01-01 00:00:00", an
     * arbitrary origin (then only differences of time are meaningful). NetCDF only. */
    const char *reference_time;
    /* The world's georeference (sq_world_crs): when crs_wkt is set, x and y
     * are written as world + offset (easting, northing in that CRS) and NetCDF fields carry
     * grid_mapping = "crs", a variable holding the WKT (crs_wkt, and GDAL's spatial_ref). */
    const char *crs_wkt;
    double crs_offset_m[2];
} sq_field_file_desc;

/* Writes fields sharing one grid (same nx, ny, nz, origin, spacing; 2D maps share x and y and
 * may lie at different levels) as netCDF-4 with CF-1.8 metadata: dimensions time (UNLIMITED,
 * one record: files of successive frames join with ncrcat), z, y, x; coordinate variables x, y,
 * z (cell centres, metres, axis and standard_name) and time; each field a float variable (time,
 * z, y, x), or (time, y, x) for a 2D map with its level as a scalar coordinate (z for a slice,
 * height above the surface for a terrain-following map, none for a surface property), carrying
 * units, long_name, standard_name (where given) and _FillValue, which marks invalid cells and
 * NaN. Written through a temporary name; the conventions are detailed in
 * src/io/netcdf_fields.c. Names must match [A-Za-z_][A-Za-z0-9_.-]* and be unique. */
SQ_API sq_result sq_netcdf_write_fields(sq_context *ctx, const sq_field_file_desc *desc,
                                        const sq_named_field *fields, int count);
/* The same grid as VTK XML ImageData (.vti, raw appended binary): each field a Float32 point
 * array on points at the cell centres (Origin = centre of cell 0, Spacing in metres), invalid
 * cells NaN; three consecutive fields u, v, w (or P_u, P_v, P_w) become one 3-component vector
 * array "wind" (or P); the time as field data "TimeValue". Written through a temporary name. */
SQ_API sq_result sq_vtk_write_fields(sq_context *ctx, const sq_field_file_desc *desc,
                                     const sq_named_field *fields, int count);
/* A ParaView time-series index (.pvd, VTK Collection): one DataSet per file with its time.
 * files are written as given (relative to the .pvd's directory). Written through a temporary
 * name; rewrite it after each new file so an interrupted run still has a complete index. */
SQ_API sq_result sq_vtk_write_series(sq_context *ctx, const char *path, const char *const *files,
                                     const double *times_s, int count, bool overwrite);

/* ---- checkpoints ----------------------------------------------------------------------------- */
struct sq_scene;
struct sq_cfg;
/* What a checkpoint says about itself. */
typedef struct sq_checkpoint_info {
    int format;          /* file format version */
    char squall[32];     /* version that wrote it */
    char build[40];      /* build id (compiler, flags, features) */
    char scene[256];     /* scene name */
    char source[256];    /* the scene file or preset it came from */
    char base_dir[512];  /* directory the scene's relative paths resolve against */
    int frame;           /* the next frame to make: frames 0..frame-1 were done */
    double time_s;       /* simulated time of the checkpoint */
} sq_checkpoint_info;
/* Writes the complete state of scene (sq_scene_save_state), the configuration it was built
 * from (cfg, overrides included) and frame (the next frame to make) to path, atomically
 * (temporary + rename: a checkpoint is whole or absent), with a checksum. Refuses a scene with
 * a layer that cannot be checkpointed (SQ_ERR_UNSUPPORTED), an input as path. */
SQ_API sq_result sq_checkpoint_write(sq_context *ctx, const char *path, bool overwrite,
                                     const struct sq_scene *scene, const struct sq_cfg *cfg,
                                     int frame);
/* Verifies path (checksum over the whole file, format, byte order, build) and reads its
 * header and configuration (*cfg_out may be NULL): create the scene from it, then restore.
 * Damaged or truncated files: SQ_ERR_PARSE; another build or format: SQ_ERR_INVALID_ARG. */
SQ_API sq_result sq_checkpoint_read_header(sq_context *ctx, const char *path,
                                           sq_checkpoint_info *info, struct sq_cfg **cfg_out);
/* Restores the state of path into scene (created from the checkpoint's configuration); refuses
 * another scene's layers or records and input files that changed since (size, mtime). */
SQ_API sq_result sq_checkpoint_restore(sq_context *ctx, const char *path, struct sq_scene *scene,
                                       sq_checkpoint_info *info);

/* ---- scene files (YAML through libyaml) ----------------------------------------------------- */
struct sq_cfg;
/* Parses YAML text into a configuration tree; errors name source:line:column. */
SQ_API sq_result sq_cfg_parse(sq_context *ctx, const char *text, size_t len, const char *source,
                              struct sq_cfg **out);
/* Reads and parses a scene file (missing/unreadable files are named). */
SQ_API sq_result sq_cfg_load_file(sq_context *ctx, const char *path, struct sq_cfg **out);
/* A built-in preset by name (SQ_ERR_NOT_FOUND lists the presets). */
SQ_API sq_result sq_cfg_load_preset(sq_context *ctx, const char *name, struct sq_cfg **out);
/* A file path if it exists (or has a .yaml/.yml ending), else a preset name. */
SQ_API sq_result sq_cfg_load(sq_context *ctx, const char *file_or_preset, struct sq_cfg **out);
/* ---- meshes (assimp) ------------------------------------------------------------------------ */
/* Reads a mesh file: glTF 2.0, OBJ, FBX or PLY (other endings are refused, SQ_ERR_INVALID_ARG).
 * Node transforms are applied, polygons triangulated, points and lines skipped; normals are
 * computed where the file has none; zero-area triangles are dropped (counted); base colours
 * (glTF baseColorFactor, else the diffuse colour) and base-colour PNG textures (files beside the
 * mesh or embedded) are kept. Refused before loading when the file (from its size, or a PLY
 * header's element counts) would exceed the context's memory limit (SQ_ERR_TOO_LARGE, with the
 * bytes). Missing/unreadable files: SQ_ERR_IO; corrupt ones: SQ_ERR_PARSE; messages name the
 * file. Without assimp in the build: SQ_ERR_UNSUPPORTED. */
SQ_API sq_result sq_mesh_import(sq_context *ctx, const sq_mesh_import_desc *desc, sq_mesh **out);
/* The mesh loader scenes use (sq_mesh_import). */
SQ_API sq_result sq_scene_mesh_loader(sq_context *ctx, const sq_mesh_import_desc *desc,
                                      sq_mesh **out);

/* The heightmap loader scenes use (16-bit PNG, at most 8192x8192). */
SQ_API sq_result sq_scene_heightmap_loader(sq_context *ctx, const char *path, uint16_t **out,
                                           int *width, int *height);

#ifdef __cplusplus
}
#endif
#endif
