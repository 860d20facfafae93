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
 * Each read-only segment of this library of 64 kB or more (its code, the one holding this function, and its
 * constants: the lookup tables' knots, a road profile's thousands) is copied into an anonymous mapping whose 2 MB-aligned
 * range the kernel backs by huge pages at the first write (madvise MADV_HUGEPAGE), given the segment's protection, and
 * moved over the segment's own addresses with mremap (atomic: the code that runs, this function included, reads the
 * same bytes before and after; a position-independent library writes nothing into its code or constants).  Done only on Linux
 * on x86-64 where transparent huge pages are on ("always" or "madvise"), not under valgrind (its tools tell functions
 * by the file mapping) and not with MBS_HUGE_TEXT=0; any failure leaves the file's mapping as it was.  The cost: one
 * copy of the code per process (1 MB for the Iltis: about 0.1 ms) and the memory of a huge page instead of the page
 * cache's shared pages. */
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

/* Pages [start, end) (whole pages) with protection prot moved onto a huge page; 0, or -1 with the mapping untouched. */
static int mbs_huge_segment(uintptr_t start, uintptr_t end, int prot)
{
    const uintptr_t page = (uintptr_t)sysconf(_SC_PAGESIZE);
    const uintptr_t from = start & ~(page - 1), size = ((end + page - 1) & ~(page - 1)) - from;
    const uintptr_t span = (size + MBS_HUGE_PAGE - 1) & ~(MBS_HUGE_PAGE - 1);  /* whole huge pages */
    uintptr_t aligned;
    char *region = (char *)mmap(NULL, span + MBS_HUGE_PAGE, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (region == (char *)MAP_FAILED) return -1;
    aligned = ((uintptr_t)region + MBS_HUGE_PAGE - 1) & ~(MBS_HUGE_PAGE - 1);
    if (madvise((void *)aligned, span, MADV_HUGEPAGE) != 0
        || (memcpy((void *)aligned, (const void *)from, size), mprotect((void *)aligned, size, prot)) != 0
        || mremap((void *)aligned, size, size, MREMAP_MAYMOVE | MREMAP_FIXED, (void *)from) == MAP_FAILED) {
        munmap(region, span + MBS_HUGE_PAGE);  /* (the file's mapping untouched) */
        return -1;
    }
    /* the rest of the anonymous region: before the aligned start, and after the moved pages */
    if (aligned > (uintptr_t)region) munmap(region, aligned - (uintptr_t)region);
    munmap((void *)(aligned + size), (uintptr_t)region + span + MBS_HUGE_PAGE - (aligned + size));
    return 0;
}

static void mbs_huge_text(void)
{
    const char *off = getenv("MBS_HUGE_TEXT"), *preload = getenv("LD_PRELOAD");
    mbs_segments seg;
    int k;
    if ((off && strcmp(off, "0") == 0) || (preload && strstr(preload, "vgpreload")) || !mbs_huge_pages_on()) return;
    memset(&seg, 0, sizeof seg);
    seg.probe = (uintptr_t)&mbs_huge_text;
    if (!dl_iterate_phdr(mbs_segments_of, &seg)) return;
    for (k = 0; k < seg.n; k++) mbs_huge_segment(seg.start[k], seg.end[k], seg.prot[k]);
}
#else
static void mbs_huge_text(void) {}
#endif
