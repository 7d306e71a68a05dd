/* The C loaders never abort the caller: bad model files (huge sizes, a NUL byte, every truncation, seeded
 * random corruptions) and allocation failures at every point of a load give a status code, never an exception
 * through the C boundary (which would be SIGABRT in a C control loop). Issue 22, item 3.
 * argv[1] = examples/02_compensation/lexos.comp. This executable is the child process: ctest fails it on abort. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "tendyn/c_api.h"

/* malloc that fails from the (fail_after+1)-th call on while armed (disarmed at -1): operator new inside the library then
 * throws std::bad_alloc, which must be caught at the C boundary. glibc keeps the real one as __libc_malloc.
 * Under AddressSanitizer (make test-asan: leaks, overflows, undefined behaviour) the sanitizer owns malloc, so the
 * failure injection is left to the plain build. */
#if defined(__SANITIZE_ADDRESS__)
#define TENDYN_WITH_ASAN 1
#endif
static long fail_after = -1;
#ifndef TENDYN_WITH_ASAN
void* __libc_malloc(size_t);
void* __libc_calloc(size_t, size_t);
void* __libc_realloc(void*, size_t);
static int should_fail(void) {
  if (fail_after < 0) return 0;
  if (fail_after == 0) return 1;
  --fail_after;
  return 0;
}
void* malloc(size_t n) { return should_fail() ? NULL : __libc_malloc(n); }
void* calloc(size_t a, size_t b) { return should_fail() ? NULL : __libc_calloc(a, b); }
void* realloc(void* p, size_t n) { return should_fail() ? NULL : __libc_realloc(p, n); }
#endif

static int failures = 0;
#define EXPECT(cond)                                 \
  do {                                               \
    if (!(cond)) {                                   \
      ++failures;                                    \
      printf("FAIL line %d: %s\n", __LINE__, #cond); \
    }                                                \
  } while (0)

static char scratch[64];

static void write_file(const char* path, const char* text, size_t size) {
  FILE* f = fopen(path, "wb");
  if (!f || fwrite(text, 1, size, f) != size) {
    printf("cannot write %s\n", path);
    exit(2);
  }
  fclose(f);
}

static char* read_file(const char* path, size_t* size) {
  FILE* f = fopen(path, "rb");
  if (!f) exit(2);
  fseek(f, 0, SEEK_END);
  *size = (size_t)ftell(f);
  fseek(f, 0, SEEK_SET);
  char* text = malloc(*size + 1);
  if (fread(text, 1, *size, f) != *size) exit(2);
  text[*size] = '\0';
  fclose(f);
  return text;
}

/* `text` with the first occurrence of `from` (after `after`) replaced by `to` (to_size bytes, may hold NUL). */
static size_t replaced(const char* text, size_t size, const char* after, const char* from, const char* to,
                       size_t to_size, char* out) {
  const char* start = strstr(text, after);
  const char* at = start ? strstr(start, from) : NULL;
  if (!at) {
    printf("'%s' not in the file\n", from);
    exit(2);
  }
  const size_t head = (size_t)(at - text), tail = size - head - strlen(from);
  memcpy(out, text, head);
  memcpy(out + head, to, to_size);
  memcpy(out + head + to_size, at + strlen(from), tail);
  return head + to_size + tail;
}

/* Both loaders on `text`; returns the compensator status. Any status is allowed but an exception crossing the
 * boundary (abort) or an internal error: a parser must refuse a bad file as an invalid model. */
static tendyn_status load_both(const char* text, size_t size, char* message) {
  char path[96];
  snprintf(path, sizeof path, "%s/x.comp", scratch);
  write_file(path, text, size);
  tendyn_transmission* t = NULL;
  const tendyn_status st = tendyn_transmission_load(path, &t, message, 512);
  EXPECT(st == TENDYN_OK || st == TENDYN_INVALID_MODEL);
  EXPECT((st == TENDYN_OK) == (t != NULL));
  tendyn_transmission_destroy(t);
  tendyn_compensator* c = NULL;
  const tendyn_status sc = tendyn_compensator_load(path, NULL, &c, message, 512);
  EXPECT(sc == TENDYN_OK || sc == TENDYN_INVALID_MODEL);
  EXPECT((sc == TENDYN_OK) == (c != NULL));
  if (c) {
    double qm[64] = {0}, tj[64] = {0}, tm[64];
    EXPECT(tendyn_compensator_cycle(c, qm, tj, tm, NULL) >= 0);
  }
  tendyn_compensator_destroy(c);
  return sc;
}

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  strcpy(scratch, "/tmp/tendyn_c_files_XXXXXX");
  if (!mkdtemp(scratch)) return 2;
  size_t size;
  char* good = read_file(argv[1], &size);
  char* buf = malloc(size + 256);
  char message[512];

  EXPECT(load_both(good, size, message) == TENDYN_OK);

  /* huge sizes are refused before anything is allocated, naming n and the limit */
  const char* huge[] = {"n 1000000000", "n 46341", "n 65", "n 1e300", "n 2.5"};
  for (int k = 0; k < 5; ++k) {
    size_t m = replaced(good, size, "", "n 4", huge[k], strlen(huge[k]), buf);
    EXPECT(load_both(buf, m, message) == TENDYN_INVALID_MODEL);
    EXPECT(strstr(message, "line 3: n: must be") != NULL);
    printf("refused: %s\n", message);
    m = replaced(good, size, "section chain", "n 4", huge[k], strlen(huge[k]), buf); /* the chain's n */
    EXPECT(load_both(buf, m, message) == TENDYN_INVALID_MODEL);
    EXPECT(strstr(message, "line 24: n: must be") != NULL);
  }
  EXPECT(strstr(message, "64") != NULL || strstr(message, "integer") != NULL);

  /* a NUL byte cuts a number short (strtod stops there): "rate_hz 1000\0" "0" must not read as 1000 */
  const char nul[] = "rate_hz 1000\0" "0";
  size_t m = replaced(good, size, "", "rate_hz 1000", nul, sizeof nul - 1, buf);
  EXPECT(load_both(buf, m, message) == TENDYN_INVALID_MODEL);
  EXPECT(strstr(message, "line 39") != NULL && strstr(message, "NUL") != NULL);
  printf("refused: %s\n", message);

  /* prismatic must be exactly 0 or 1 (a cast read 1.5 as 1) */
  m = replaced(good, size, "", "prismatic 0", "prismatic 1.5", 13, buf);
  EXPECT(load_both(buf, m, message) == TENDYN_INVALID_MODEL && strstr(message, "prismatic[0]") != NULL);

  /* an empty expected device is a mistake, not "any device" */
  char path[96];
  snprintf(path, sizeof path, "%s/good.comp", scratch);
  write_file(path, good, size);
  tendyn_compensator* c = NULL;
  EXPECT(tendyn_compensator_load(path, "", &c, message, sizeof message) == TENDYN_INVALID_MODEL && c == NULL);
  EXPECT(strstr(message, "expected_device") != NULL);

  /* every truncation of a valid file */
  int refused = 0;
  for (size_t k = 0; k < size; ++k) refused += load_both(good, k, message) == TENDYN_INVALID_MODEL;
  EXPECT(refused > 0);

  /* seeded random corruptions: bytes replaced by random bytes, digits, NUL, huge numbers */
  uint64_t state = 0x2545F4914F6CDD1DULL;
  const char* inserts[] = {"1e308", "999999999999", "-1", "nan", "\0", "\n", " ", "#", "section chain 1\n"};
  for (int trial = 0; trial < 3000; ++trial) {
    memcpy(buf, good, size);
    size_t len = size;
    const int edits = 1 + (int)(state % 4);
    for (int e = 0; e < edits; ++e) {
      state ^= state << 13, state ^= state >> 7, state ^= state << 17;
      const size_t at = (size_t)(state >> 11) % len;
      if (state & 1) {
        buf[at] = (char)(state >> 3);
      } else {
        const char* ins = inserts[(state >> 5) % 9];
        const size_t k = strlen(ins) ? strlen(ins) : 1;
        if (len + k > size + 200) continue;
        memmove(buf + at + k, buf + at, len - at);
        memcpy(buf + at, ins, k);
        len += k;
      }
    }
    load_both(buf, len, message);
  }

  /* whole files of random bytes, and of random keywords and numbers (what a parser meets in a wrong file) */
  const char* words[] = {"tendyn-transmission-model 1", "section chain 1", "section compensator 1",
                         "section losses 1", "n", "K", "motor_radius", "parent", "placement", "mass", "device",
                         "rate_hz", "tau0", "bearing_n0", "0", "1", "4", "-1", "1e308", "46341", "1000000000", "nan",
                         "0.5", "L-EXOS", "\n", "#", " "};
  const int n_words = (int)(sizeof words / sizeof words[0]);
  for (int trial = 0; trial < 600; ++trial) {
    state ^= state << 13, state ^= state >> 7, state ^= state << 17;
    size_t len = 0;
    const size_t target = (size_t)(state >> 20) % (size + 200);
    while (len < target) {
      state ^= state << 13, state ^= state >> 7, state ^= state << 17;
      if (trial % 2 == 0) {
        buf[len++] = (char)(state >> 24);
      } else {
        const char* w = words[(state >> 24) % (uint64_t)n_words];
        const size_t k = strlen(w);
        if (len + k + 1 > size + 200) break;
        memcpy(buf + len, w, k);
        len += k;
        buf[len++] = (state >> 40) % 3 ? ' ' : '\n';
      }
    }
    if (trial % 2 == 1 && len > 27) memcpy(buf, "tendyn-transmission-model 1\n", 28); /* past the magic line */
    load_both(buf, len, message);
  }

#ifndef TENDYN_WITH_ASAN
  /* allocation failure at every point of both loads: a status, never an abort (std::bad_alloc caught) */
  int internal = 0;
  for (long k = 0; k < 2000; ++k) {
    tendyn_compensator* cc = NULL;
    tendyn_transmission* tt = NULL;
    fail_after = k;
    const tendyn_status sc = tendyn_compensator_load(path, "L-EXOS", &cc, message, sizeof message);
    fail_after = k;
    const tendyn_status st = tendyn_transmission_load(path, &tt, message, sizeof message);
    fail_after = -1;
    EXPECT(sc == TENDYN_OK || sc == TENDYN_INVALID_MODEL || sc == TENDYN_INTERNAL_ERROR);
    EXPECT(st == TENDYN_OK || st == TENDYN_INVALID_MODEL || st == TENDYN_INTERNAL_ERROR);
    EXPECT((sc == TENDYN_OK) == (cc != NULL) && (st == TENDYN_OK) == (tt != NULL));
    internal += sc == TENDYN_INTERNAL_ERROR;
    if (sc == TENDYN_INTERNAL_ERROR && internal == 1) {
      printf("caught: %s\n", message);
      EXPECT(strstr(message, "out of memory") != NULL);
    }
    tendyn_compensator_destroy(cc);
    tendyn_transmission_destroy(tt);
    if (sc == TENDYN_OK && st == TENDYN_OK) break; /* past the last allocation of both loads */
  }
  EXPECT(internal > 0);
#endif

  snprintf(path, sizeof path, "%s/x.comp", scratch);
  remove(path);
  snprintf(path, sizeof path, "%s/good.comp", scratch);
  remove(path);
  rmdir(scratch);
  free(buf);
  free(good);
  if (failures) printf("%d failures\n", failures);
  else puts("C loaders on bad files: ok");
  return failures ? 1 : 0;
}
