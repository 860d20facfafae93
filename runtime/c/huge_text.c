/* The model library's code and constants moved onto transparent huge pages when the module is created
 * (mbs_python_module).
 *
 * The CPU's caches below the first level are indexed by physical address.  A model's hot code is long straight-line
 * code (the Iltis's mbs_loop_terms alone about 120 kB, run once per right-hand side), and the 4 kB pages the file's
 * page cache gives it land anywhere in physical memory: how many of them share a cache set is luck, fixed until the
 * file is copied afresh.  The same library, byte for byte, ran the Iltis's right-hand side at 2.05 us from one copy
 * of its file and 2.45 us from another (bench/rhs_placement.py), its bump at 10 m/s between 23.7 and 27.3 ms
 * (bench/bump_placements.py).  Copied into a 2 MB huge page, the code is contiguous in physical memory, so its
 * pages spread evenly over the cache sets in every process.
 *
 * The read-only segments of this library of 64 kB or more (its code, the one holding this function, and its
 * constants: the lookup tables' knots, a road profile's thousands) are copied one after another into an anonymous
 * mapping whose 2 MB-aligned range the kernel backs by huge pages at the first write (madvise MADV_HUGEPAGE), each
 * given its protection and moved over its own addresses with mremap (atomic: the code that runs, this function
 * included, reads the same bytes before and after; a position-independent library writes nothing into its code or
 * constants).  Done only on Linux on x86-64 where transparent huge pages are on ("always" or "madvise"), not under
 * valgrind (its tools tell functions by the file mapping) and not with MBS_HUGE_TEXT=0; any failure leaves the file's
 * mapping as it was.  The cost: one copy of the code and constants per process (1 MB for the Iltis: about 0.1 ms)
 * and the memory of a huge page instead of the page
 * cache's shared pages (the part of the last huge page beyond the segments is unmapped; the kernel frees it when it
 * splits the page under memory pressure). */
#if defined(__linux__) && defined(__x86_64__)
#include <link.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#define MBS_HUGE_PAGE ((uintptr_t)2 << 20)

#define MBS_HUGE_MIN ((uintptr_t)64 << 10)  /* segments smaller than this stay where they are */
#define MBS_HUGE_SEGMENTS 8

typedef struct {
    uintptr_t probe;                       /* an address inside the library looked for (its code) */
    int n;                                 /* its read-only segments found (0: none) */
    uintptr_t start[MBS_HUGE_SEGMENTS], end[MBS_HUGE_SEGMENTS];
    int prot[MBS_HUGE_SEGMENTS];
} mbs_segments;

/* The read-only segments (code, constants) of the object whose executable segment holds s->probe. */
static int mbs_segments_of(struct dl_phdr_info *info, size_t size, void *data)
{
    mbs_segments *s = (mbs_segments *)data;
    int i, mine = 0;
    (void)size;
    for (i = 0; i < info->dlpi_phnum; i++) {
        const ElfW(Phdr) *ph = &info->dlpi_phdr[i];
        const uintptr_t start = (uintptr_t)info->dlpi_addr + ph->p_vaddr, end = start + ph->p_memsz;
        if (ph->p_type == PT_LOAD && (ph->p_flags & PF_X) && s->probe >= start && s->probe < end) mine = 1;
    }
    if (!mine) return 0;
    for (i = 0; i < info->dlpi_phnum && s->n < MBS_HUGE_SEGMENTS; i++) {
        const ElfW(Phdr) *ph = &info->dlpi_phdr[i];
        if (ph->p_type != PT_LOAD || (ph->p_flags & PF_W) || ph->p_memsz < MBS_HUGE_MIN) continue;
        s->start[s->n] = (uintptr_t)info->dlpi_addr + ph->p_vaddr;
        s->end[s->n] = s->start[s->n] + ph->p_memsz;
        s->prot[s->n] = PROT_READ | ((ph->p_flags & PF_X) ? PROT_EXEC : 0);
        s->n++;
    }
    return 1;
}

/* Whether the kernel gives huge pages to an anonymous mapping that asks (the setting's chosen word in brackets). */
static int mbs_huge_pages_on(void)
{
    char line[128] = "";
    FILE *f = fopen("/sys/kernel/mm/transparent_hugepage/enabled", "r");
    if (!f) return 0;
    if (!fgets(line, sizeof line, f)) line[0] = '\0';
    fclose(f);
    return strstr(line, "[always]") != NULL || strstr(line, "[madvise]") != NULL;
}

/* The segments' pages copied one after another into one run of huge pages (2 MB for the Iltis's code and constants
 * together), each given its protection and moved over its own addresses; a segment whose move fails keeps the file's
 * mapping. */
static void mbs_huge_segments(const mbs_segments *seg)
{
    const uintptr_t page = (uintptr_t)sysconf(_SC_PAGESIZE);
    uintptr_t from[MBS_HUGE_SEGMENTS], size[MBS_HUGE_SEGMENTS], total = 0, span, aligned, at;
    char *region;
    int k, n;
    for (n = 0; n < seg->n; n++) {
        from[n] = seg->start[n] & ~(page - 1);
        size[n] = ((seg->end[n] + page - 1) & ~(page - 1)) - from[n];
        if (n > 0 && from[n] < from[n - 1] + size[n - 1]) break;  /* a page shared with the segment before (its
                                                                      * protection would be overwritten): not moved */
        total += size[n];
    }
    if (n == 0) return;
    span = (total + MBS_HUGE_PAGE - 1) & ~(MBS_HUGE_PAGE - 1);  /* whole huge pages */
    region = (char *)mmap(NULL, span + MBS_HUGE_PAGE, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (region == (char *)MAP_FAILED) return;
    aligned = ((uintptr_t)region + MBS_HUGE_PAGE - 1) & ~(MBS_HUGE_PAGE - 1);
    at = aligned;
    if (madvise((void *)aligned, span, MADV_HUGEPAGE) == 0) {
        for (k = 0; k < n; at += size[k], k++) {
            memcpy((void *)at, (const void *)from[k], size[k]);
            if (mprotect((void *)at, size[k], seg->prot[k]) != 0
                || mremap((void *)at, size[k], size[k], MREMAP_MAYMOVE | MREMAP_FIXED, (void *)from[k]) == MAP_FAILED)
                break;  /* (this segment and the later ones keep the file's mapping) */
        }
    }
    /* what is left of the anonymous region, exactly (a hole the moves left may hold another thread's mapping by now):
     * before the aligned start, and from the first segment not moved on */
    if (aligned > (uintptr_t)region) munmap(region, aligned - (uintptr_t)region);
    munmap((void *)at, (uintptr_t)region + span + MBS_HUGE_PAGE - at);
}

static void mbs_huge_text(void)
{
    static int done;  /* once per library (a module created again must not move code another thread may run) */
    const char *off = getenv("MBS_HUGE_TEXT"), *preload = getenv("LD_PRELOAD");
    mbs_segments seg;
    if (done) return;
    done = 1;
    if ((off && strcmp(off, "0") == 0) || (preload && strstr(preload, "vgpreload")) || !mbs_huge_pages_on()) return;
    memset(&seg, 0, sizeof seg);
    seg.probe = (uintptr_t)&mbs_huge_text;
    if (dl_iterate_phdr(mbs_segments_of, &seg) && seg.n > 0) mbs_huge_segments(&seg);
}
#else
static void mbs_huge_text(void) {}
#endif
