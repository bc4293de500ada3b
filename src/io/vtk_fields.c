/* vtk_fields.c — field output as VTK XML ImageData (.vti) for ParaView/VisIt (issue 3 part 5).
 *
 * The fields are cell-centred; they are written as point data of an image whose points are the
 * cell centres: Origin = centre of cell (0,0,0), Spacing = cell size (metres), WholeExtent
 * 0..nx-1, 0..ny-1, 0..nz-1 (nz = 1 gives a flat image). Each field is a Float32 DataArray in the
 * appended section, raw binary in the host's byte order (declared in byte_order) with a UInt64
 * byte-count header per array; the time is field data "TimeValue" (ParaView reads it). Units and
 * long names ride along as extra attributes of each DataArray, which VTK readers ignore.
 * Written to a temporary name and renamed when complete (output.c). */
#include <errno.h>
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

static void write_xml(FILE *fp, const sq_field_file_desc *desc, const sq_named_field *fields,
                      int count)
{
    const sq_named_field *g = &fields[0];
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
            "  <ImageData WholeExtent=\"%s\" Origin=\"%.9g %.9g %.9g\" Spacing=\"%.9g %.9g %.9g\" "
            "Direction=\"1 0 0 0 1 0 0 0 1\">\n",
            extent, (double)g->origin_m.x, (double)g->origin_m.y, (double)g->origin_m.z,
            (double)g->spacing_m.x, (double)g->spacing_m.y, (double)g->spacing_m.z);
    fprintf(fp,
            "    <FieldData>\n"
            "      <DataArray type=\"Float64\" Name=\"TimeValue\" NumberOfTuples=\"1\" "
            "format=\"ascii\">%.17g</DataArray>\n"
            "    </FieldData>\n",
            desc->time_s);
    fprintf(fp, "    <Piece Extent=\"%s\">\n", extent);
    fputs("      <PointData Scalars=\"", fp);
    put_escaped(fp, g->name);
    fputs("\">\n", fp);
    const uint64_t bytes = (uint64_t)g->nx * (uint64_t)g->ny * (uint64_t)g->nz * sizeof(float);
    for (int i = 0; i < count; i++) {
        const sq_named_field *f = &fields[i];
        fputs("        <DataArray type=\"Float32\" Name=\"", fp);
        put_escaped(fp, f->name);
        fputs("\" NumberOfComponents=\"1\"", fp);
        if (f->units && *f->units) {
            fputs(" units=\"", fp);
            put_escaped(fp, f->units);
            fputc('"', fp);
        }
        if (f->long_name && *f->long_name) {
            fputs(" long_name=\"", fp);
            put_escaped(fp, f->long_name);
            fputc('"', fp);
        }
        fprintf(fp, " format=\"appended\" offset=\"%llu\"/>\n",
                (unsigned long long)((uint64_t)i * (bytes + sizeof(uint64_t))));
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

sq_result sq_vtk_write_fields(sq_context *ctx, const sq_field_file_desc *desc,
                              const sq_named_field *fields, int count)
{
    sq_result r = sq__field_file_check(ctx, desc, fields, count, "VTK file");
    if (r != SQ_OK) return r;
    char tmp[SQ__TEMP_NAME_MAX];
    int fd = -1;
    r = sq__output_open_temp(desc->path, desc->overwrite, tmp, sizeof tmp, &fd);
    if (r != SQ_OK) return sq__io_relog(ctx, r);
    FILE *fp = fdopen(fd, "wb");
    if (!fp) {
        int e = errno;
        close(fd);
        sq__output_discard(tmp);
        return sq__fail(ctx, SQ_ERR_IO, "io", "cannot write '%s': %s", desc->path, strerror(e));
    }
    write_xml(fp, desc, fields, count);
    const sq_named_field *g = &fields[0];
    const size_t n = (size_t)g->nx * (size_t)g->ny * (size_t)g->nz;
    const uint64_t bytes = (uint64_t)n * sizeof(float);
    for (int i = 0; i < count && !ferror(fp); i++) {
        if (fwrite(&bytes, sizeof bytes, 1, fp) != 1) break;
        if (fwrite(fields[i].data, sizeof(float), n, fp) != n) break;
    }
    fputs("\n  </AppendedData>\n</VTKFile>\n", fp);
    int e = ferror(fp) ? (errno ? errno : EIO) : 0;
    if (fclose(fp) != 0 && !e) e = errno ? errno : EIO;
    if (e) {
        sq__output_discard(tmp);
        return sq__fail(ctx, SQ_ERR_IO, "io", "cannot write '%s': %s", desc->path, strerror(e));
    }
    r = sq__io_relog(ctx, sq__output_finish(tmp, desc->path, desc->overwrite));
    if (r == SQ_OK) sq_log(ctx, SQ_LOG_INFO, "io", "wrote '%s' (%d fields)", desc->path, count);
    return r;
}
