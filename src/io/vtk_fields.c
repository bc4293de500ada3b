/* vtk_fields.c — field output as VTK XML ImageData (.vti) for ParaView/VisIt (issue 3 part 5,
 * issue 17 part 7), and the .pvd time-series index.
 *
 * The fields are cell-centred; they are written as point data of an image whose points are the
 * cell centres: Origin = centre of cell (0,0,0) (for a georeferenced world, x and y + the CRS
 * offset), Spacing = cell size (metres), WholeExtent 0..nx-1, 0..ny-1, 0..nz-1 (nz = 1 gives a
 * flat image at the map's level). Each array is Float32 in the appended section, raw binary in
 * the host's byte order (declared in byte_order) with a UInt64 byte-count header per array;
 * cells a field marks invalid (inside solids, below the ground) are NaN, which ParaView shows
 * as missing. Three consecutive fields u, v, w (or P_u, P_v, P_w) are one 3-component vector
 * array "wind" (or "P"), the PointData's Vectors, so glyphs and stream tracers take it as it is.
 * The time is field data "TimeValue" (ParaView reads it). Units and long names ride along as
 * extra attributes of each DataArray, which VTK readers ignore. Written to a temporary name and
 * renamed when complete (output.c). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "io/io_internal.h"

/* Writes s with the five XML special characters escaped. */
static void put_escaped(FILE *fp, const char *s)
{
    for (; *s; s++) {
        switch (*s) {
        case '&': fputs("&amp;", fp); break;
        case '<': fputs("&lt;", fp); break;
        case '>': fputs("&gt;", fp); break;
        case '"': fputs("&quot;", fp); break;
        case '\'': fputs("&apos;", fp); break;
        default:
            /* Control characters are not allowed in XML 1.0 attributes: drop them. */
            if ((unsigned char)*s >= 0x20 || *s == '\t') fputc(*s, fp);
        }
    }
}

static bool host_is_little_endian(void)
{
    const uint16_t one = 1;
    unsigned char b;
    memcpy(&b, &one, 1);
    return b == 1;
}

/* One array of the file: a scalar field, or three fields as a vector. */
typedef struct vtk_array {
    const sq_named_field *f[3];
    int ncomp;
    char name[136];
} vtk_array;

/* Suffix check: name is exactly c ("u") or ends with "_" c ("wind_u"); prefix length out. */
static bool component_of(const char *name, char c, size_t *prefix)
{
    const size_t n = strlen(name);
    if (n == 1 && name[0] == c) {
        *prefix = 0;
        return true;
    }
    if (n >= 3 && name[n - 1] == c && name[n - 2] == '_') {
        *prefix = n - 2;
        return true;
    }
    return false;
}

static int group_arrays(const sq_named_field *fields, int count, vtk_array *out)
{
    int n = 0;
    for (int i = 0; i < count; i++) {
        size_t pu, pv, pw;
        vtk_array *a = &out[n++];
        if (i + 2 < count && component_of(fields[i].name, 'u', &pu) &&
            component_of(fields[i + 1].name, 'v', &pv) &&
            component_of(fields[i + 2].name, 'w', &pw) && pu == pv && pv == pw &&
            strncmp(fields[i].name, fields[i + 1].name, pu) == 0 &&
            strncmp(fields[i].name, fields[i + 2].name, pu) == 0) {
            a->ncomp = 3;
            for (int c = 0; c < 3; c++) a->f[c] = &fields[i + c];
            if (pu == 0)
                snprintf(a->name, sizeof a->name, "wind");
            else
                snprintf(a->name, sizeof a->name, "%.*s", (int)pu, fields[i].name);
            i += 2;
        } else {
            a->ncomp = 1;
            a->f[0] = &fields[i];
            a->f[1] = a->f[2] = NULL;
            snprintf(a->name, sizeof a->name, "%s", fields[i].name);
        }
    }
    return n;
}

static void write_xml(FILE *fp, const sq_field_file_desc *desc, const vtk_array *arrays,
                      int narrays)
{
    const sq_named_field *g = arrays[0].f[0];
    const bool georef = desc->crs_wkt && *desc->crs_wkt;
    const double ox = (double)g->origin_m.x + (georef ? desc->crs_offset_m[0] : 0.0);
    const double oy = (double)g->origin_m.y + (georef ? desc->crs_offset_m[1] : 0.0);
    const double oz = g->nz == 1 && g->level == SQ_FIELD_LEVEL_SURFACE ? 0.0 : (double)g->origin_m.z;
    char extent[96];
    snprintf(extent, sizeof extent, "0 %d 0 %d 0 %d", g->nx - 1, g->ny - 1, g->nz - 1);
    fputs("<?xml version=\"1.0\"?>\n", fp);
    fprintf(fp, "<!-- written by squall %s", SQ_VERSION_STRING);
    if (desc->title && *desc->title) {
        fputs(": ", fp);
        /* "--" may not appear inside an XML comment. */
        for (const char *s = desc->title; *s; s++)
            if (!(s[0] == '-' && s[1] == '-') && (unsigned char)*s >= 0x20) fputc(*s, fp);
    }
    fputs(" -->\n", fp);
    fprintf(fp,
            "<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"%s\" "
            "header_type=\"UInt64\">\n",
            host_is_little_endian() ? "LittleEndian" : "BigEndian");
    fprintf(fp,
            "  <ImageData WholeExtent=\"%s\" Origin=\"%.17g %.17g %.17g\" Spacing=\"%.9g %.9g "
            "%.9g\" Direction=\"1 0 0 0 1 0 0 0 1\">\n",
            extent, ox, oy, oz, (double)g->spacing_m.x, (double)g->spacing_m.y,
            (double)g->spacing_m.z);
    fprintf(fp,
            "    <FieldData>\n"
            "      <DataArray type=\"Float64\" Name=\"TimeValue\" NumberOfTuples=\"1\" "
            "format=\"ascii\">%.17g</DataArray>\n"
            "    </FieldData>\n",
            desc->time_s);
    fprintf(fp, "    <Piece Extent=\"%s\">\n", extent);
    fputs("      <PointData", fp);
    for (int k = 0; k < narrays; k++)
        if (arrays[k].ncomp == 1) {
            fputs(" Scalars=\"", fp);
            put_escaped(fp, arrays[k].name);
            fputc('"', fp);
            break;
        }
    for (int k = 0; k < narrays; k++)
        if (arrays[k].ncomp == 3) {
            fputs(" Vectors=\"", fp);
            put_escaped(fp, arrays[k].name);
            fputc('"', fp);
            break;
        }
    fputs(">\n", fp);
    const uint64_t points = (uint64_t)g->nx * (uint64_t)g->ny * (uint64_t)g->nz;
    uint64_t offset = 0;
    for (int k = 0; k < narrays; k++) {
        const sq_named_field *f = arrays[k].f[0];
        fputs("        <DataArray type=\"Float32\" Name=\"", fp);
        put_escaped(fp, arrays[k].name);
        fprintf(fp, "\" NumberOfComponents=\"%d\"", arrays[k].ncomp);
        if (f->units && *f->units) {
            fputs(" units=\"", fp);
            put_escaped(fp, f->units);
            fputc('"', fp);
        }
        if (arrays[k].ncomp == 1 && f->long_name && *f->long_name) {
            fputs(" long_name=\"", fp);
            put_escaped(fp, f->long_name);
            fputc('"', fp);
        }
        fprintf(fp, " format=\"appended\" offset=\"%llu\"/>\n", (unsigned long long)offset);
        offset += sizeof(uint64_t) + points * (uint64_t)arrays[k].ncomp * sizeof(float);
    }
    fputs("      </PointData>\n"
          "      <CellData>\n"
          "      </CellData>\n"
          "    </Piece>\n"
          "  </ImageData>\n"
          "  <AppendedData encoding=\"raw\">\n"
          "   _",
          fp);
}

/* Writes one array's values (components interleaved, invalid cells and NaN as NaN) through a
 * bounded buffer. Returns false on a write error. */
static bool write_values(FILE *fp, const vtk_array *a, size_t n, float *buf, size_t buf_points)
{
    const uint64_t bytes = (uint64_t)n * (uint64_t)a->ncomp * sizeof(float);
    if (fwrite(&bytes, sizeof bytes, 1, fp) != 1) return false;
    for (size_t p0 = 0; p0 < n; p0 += buf_points) {
        const size_t m = n - p0 < buf_points ? n - p0 : buf_points;
        for (int c = 0; c < a->ncomp; c++) {
            const sq_named_field *f = a->f[c];
            for (size_t p = 0; p < m; p++) {
                const size_t id = p0 + p;
                buf[p * (size_t)a->ncomp + (size_t)c] =
                    f->invalid && f->invalid[id] ? NAN : f->data[id];
            }
        }
        if (fwrite(buf, sizeof(float) * (size_t)a->ncomp, m, fp) != m) return false;
    }
    return true;
}

sq_result sq_vtk_write_fields(sq_context *ctx, const sq_field_file_desc *desc,
                              const sq_named_field *fields, int count)
{
    sq_result r = sq__field_file_check(ctx, desc, fields, count, "VTK file");
    if (r != SQ_OK) return r;
    vtk_array *arrays = (vtk_array *)sq_alloc(ctx, sizeof(vtk_array) * (size_t)count);
    const size_t buf_points = 1 << 16;
    float *buf = (float *)sq_alloc(ctx, sizeof(float) * 3 * buf_points);
    if (!arrays || !buf) {
        sq_free(ctx, arrays);
        sq_free(ctx, buf);
        return sq__io_relog(ctx, SQ_ERR_OUT_OF_MEMORY);
    }
    const int narrays = group_arrays(fields, count, arrays);
    char tmp[SQ__TEMP_NAME_MAX];
    int fd = -1;
    r = sq_output_check_inputs(ctx, desc->path, false);
    if (r == SQ_OK) r = sq__output_open_temp(desc->path, desc->overwrite, tmp, sizeof tmp, &fd);
    if (r != SQ_OK) {
        sq_free(ctx, arrays);
        sq_free(ctx, buf);
        return sq__io_relog(ctx, r);
    }
    FILE *fp = fdopen(fd, "wb");
    if (!fp) {
        int e = errno;
        close(fd);
        sq__output_discard(tmp);
        sq_free(ctx, arrays);
        sq_free(ctx, buf);
        return sq__fail(ctx, SQ_ERR_IO, "io", "cannot write '%s': %s", desc->path, strerror(e));
    }
    write_xml(fp, desc, arrays, narrays);
    const sq_named_field *g = &fields[0];
    const size_t n = (size_t)g->nx * (size_t)g->ny * (size_t)g->nz;
    errno = 0;
    bool ok = !ferror(fp);
    for (int i = 0; i < narrays && ok; i++) ok = write_values(fp, &arrays[i], n, buf, buf_points);
    fputs("\n  </AppendedData>\n</VTKFile>\n", fp);
    int e = ok && !ferror(fp) ? 0 : (errno ? errno : EIO);
    if (fclose(fp) != 0 && !e) e = errno ? errno : EIO;
    sq_free(ctx, arrays);
    sq_free(ctx, buf);
    if (e) {
        sq__output_discard(tmp);
        return sq__write_error(ctx, desc->path, e, NULL);
    }
    r = sq__io_relog(ctx, sq__output_finish(tmp, desc->path, desc->overwrite));
    if (r == SQ_OK) sq_log(ctx, SQ_LOG_INFO, "io", "wrote '%s' (%d fields)", desc->path, count);
    return r;
}

sq_result sq_vtk_write_series(sq_context *ctx, const char *path, const char *const *files,
                              const double *times_s, int count, bool overwrite)
{
    if (!path || !*path) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "series path is empty");
    if (count < 0 || (count > 0 && (!files || !times_s)))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "series '%s': %d entries without data", path,
                        count);
    char tmp[SQ__TEMP_NAME_MAX];
    int fd = -1;
    sq_result r = sq__output_open_temp(path, overwrite, tmp, sizeof tmp, &fd);
    if (r != SQ_OK) return sq__io_relog(ctx, r);
    FILE *fp = fdopen(fd, "wb");
    if (!fp) {
        int e = errno;
        close(fd);
        sq__output_discard(tmp);
        return sq__fail(ctx, SQ_ERR_IO, "io", "cannot write '%s': %s", path, strerror(e));
    }
    errno = 0;
    fprintf(fp, "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" "
                "byte_order=\"%s\">\n  <Collection>\n",
            host_is_little_endian() ? "LittleEndian" : "BigEndian");
    for (int i = 0; i < count; i++) {
        fprintf(fp, "    <DataSet timestep=\"%.17g\" group=\"\" part=\"0\" file=\"", times_s[i]);
        put_escaped(fp, files[i] ? files[i] : "");
        fputs("\"/>\n", fp);
    }
    fputs("  </Collection>\n</VTKFile>\n", fp);
    int e = ferror(fp) ? (errno ? errno : EIO) : 0;
    if (fclose(fp) != 0 && !e) e = errno ? errno : EIO;
    if (e) {
        sq__output_discard(tmp);
        return sq__write_error(ctx, path, e, NULL);
    }
    return sq__io_relog(ctx, sq__output_finish(tmp, path, overwrite));
}
