/* replay_main.c — runs a libFuzzer harness without libFuzzer: every file named on the command
 * line, and every regular file in every directory named, is passed once to
 * LLVMFuzzerTestOneInput (sorted by name, so runs are repeatable). This is how the corpus and
 * the regression inputs (tests/fuzz/regress/) run in the ordinary Release and ASan+UBSan test
 * suites, with gcc too. A harness reports a broken invariant by aborting. */
#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* One allocation larger than this is a finding: no input of a few kilobytes has a reason to ask
 * for it (under ASan, ASAN_OPTIONS=max_allocation_size_mb=256 says the same; without ASan the
 * malloc family is wrapped here, which also covers the shared libraries the readers use). */
#define REPLAY_MAX_ALLOCATION ((size_t)256 << 20)

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define REPLAY_UNDER_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define REPLAY_UNDER_ASAN 1
#endif

#if !defined(REPLAY_UNDER_ASAN) && defined(__GLIBC__)
extern void *__libc_malloc(size_t size);
extern void *__libc_calloc(size_t n, size_t size);
extern void *__libc_realloc(void *p, size_t size);
void *malloc(size_t size);
void *calloc(size_t n, size_t size);
void *realloc(void *p, size_t size);

static void too_large(size_t size)
{
    char msg[128];
    int len = snprintf(msg, sizeof msg, "replay: FINDING: one allocation of %zu bytes (limit %zu)\n",
                       size, REPLAY_MAX_ALLOCATION);
    if (len > 0) fwrite(msg, 1, (size_t)len, stderr);
    abort();
}

void *malloc(size_t size)
{
    if (size > REPLAY_MAX_ALLOCATION) too_large(size);
    return __libc_malloc(size);
}

void *calloc(size_t n, size_t size)
{
    if (size && n > REPLAY_MAX_ALLOCATION / size) too_large(n * size);
    return __libc_calloc(n, size);
}

void *realloc(void *p, size_t size)
{
    if (size > REPLAY_MAX_ALLOCATION) too_large(size);
    return __libc_realloc(p, size);
}
#endif

static int run_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "replay: cannot open '%s'\n", path);
        return 1;
    }
    size_t cap = 1 << 16, n = 0;
    uint8_t *buf = (uint8_t *)malloc(cap);
    while (buf) {
        size_t got = fread(buf + n, 1, cap - n, f);
        n += got;
        if (n < cap) break;
        uint8_t *nb = (uint8_t *)realloc(buf, cap * 2);
        if (!nb) {
            free(buf);
            buf = NULL;
            break;
        }
        buf = nb;
        cap *= 2;
    }
    fclose(f);
    if (!buf) {
        fprintf(stderr, "replay: out of memory reading '%s'\n", path);
        return 1;
    }
    /* a copy of exactly n bytes, so ASan sees reads past the end of the input */
    uint8_t *exact = (uint8_t *)malloc(n ? n : 1);
    if (!exact) {
        free(buf);
        return 1;
    }
    memcpy(exact, buf, n);
    free(buf);
    fprintf(stderr, "replay: %s (%zu bytes)\n", path, n);
    LLVMFuzzerTestOneInput(exact, n);
    free(exact);
    return 0;
}

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static int run_dir(const char *dir, int *count)
{
    DIR *d = opendir(dir);
    if (!d) return 0; /* a harness may have no regression inputs yet */
    char **names = NULL;
    size_t n = 0, cap = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.') continue;
        if (n == cap) {
            cap = cap ? cap * 2 : 64;
            char **nn = (char **)realloc(names, cap * sizeof *names);
            if (!nn) break;
            names = nn;
        }
        names[n] = (char *)malloc(strlen(dir) + strlen(e->d_name) + 2);
        if (!names[n]) break;
        sprintf(names[n], "%s/%s", dir, e->d_name);
        n++;
    }
    closedir(d);
    if (n > 1) qsort(names, n, sizeof *names, cmp_str); /* names is NULL for an empty folder */
    int bad = 0;
    for (size_t i = 0; i < n; i++) {
        struct stat st;
        if (stat(names[i], &st) == 0 && S_ISREG(st.st_mode)) {
            bad |= run_file(names[i]);
            (*count)++;
        }
        free(names[i]);
    }
    free(names);
    return bad;
}

int main(int argc, char **argv)
{
    int bad = 0, count = 0;
    for (int i = 1; i < argc; i++) {
        struct stat st;
        if (stat(argv[i], &st) == 0 && S_ISDIR(st.st_mode)) {
            bad |= run_dir(argv[i], &count);
        } else {
            bad |= run_file(argv[i]);
            count++;
        }
    }
    fprintf(stderr, "replay: %d input%s%s\n", count, count == 1 ? "" : "s",
            bad ? ", some could not be read" : ", no invariant broken");
    return bad;
}
