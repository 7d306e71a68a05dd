/* The compensator and renderer through the C ABI: load, refuse a file of another device with a message
 * naming the field, NULL arguments, cycles, the renderer. argv[1] = examples/02_compensation/lexos.comp. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "tendyn/c_api.h"

static int failures = 0;
#define EXPECT(cond)                                              \
  do {                                                            \
    if (!(cond)) {                                                \
      ++failures;                                                 \
      printf("FAIL line %d: %s\n", __LINE__, #cond);              \
    }                                                             \
  } while (0)

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  char message[512];
  tendyn_compensator* c = NULL;
  EXPECT(tendyn_compensator_load("/nonexistent.comp", NULL, &c, message, sizeof message) == TENDYN_INVALID_MODEL);
  EXPECT(c == NULL && strstr(message, "nonexistent.comp") != NULL);
  EXPECT(tendyn_compensator_load(argv[1], "CEA branch", &c, message, sizeof message) == TENDYN_INVALID_MODEL);
  EXPECT(c == NULL && strstr(message, "device") != NULL);
  printf("refused: %s\n", message);
  EXPECT(tendyn_compensator_load(argv[1], "L-EXOS", &c, message, sizeof message) == TENDYN_OK);
  if (!c) return 1;
  EXPECT(tendyn_compensator_size(c) == 4);
  double qm[4] = {0.1, 0.2, 0.3, 0.4}, tj[4] = {0, 0, 0, 0}, tm[4], g[4], x[3], dt = -1.0;
  EXPECT(tendyn_compensator_cycle(c, NULL, tj, tm, NULL) == TENDYN_NULL_ARGUMENT);
  EXPECT(tendyn_compensator_cycle(c, qm, tj, tm, &dt) >= 0 && dt >= 0.0);
  EXPECT(tendyn_compensator_state(c, NULL, NULL, NULL, g, x) == TENDYN_OK);
  EXPECT(isfinite(tm[0]) && isfinite(g[1]) && isfinite(x[2]));
  qm[0] = NAN;
  EXPECT(tendyn_compensator_cycle(c, qm, tj, tm, NULL) == TENDYN_NON_FINITE_INPUT);
  qm[0] = 0.1;
  double f[3] = {0, 0, 1.0};
  EXPECT(tendyn_compensator_cycle_force(c, qm, f, tm, NULL) >= 0);
  tendyn_renderer* r = NULL;
  EXPECT(tendyn_renderer_create(c, 2000.0, 5.0, 0.3, &r) == TENDYN_OK && r != NULL);
  double up[3] = {0, 0, 1}, bad[3] = {0, 0, 2}, center[3] = {0.3, 0, -0.3}, xg[3], fe[3];
  EXPECT(tendyn_renderer_add_plane(r, up, -0.35) == TENDYN_OK);
  EXPECT(tendyn_renderer_add_plane(r, bad, 0.0) == TENDYN_INVALID_MODEL);
  EXPECT(tendyn_renderer_set_sphere(r, center, 0.05) == TENDYN_OK);
  EXPECT(tendyn_renderer_set_texture(r, 0.1, 0.01, up) == TENDYN_OK);
  EXPECT(tendyn_renderer_cycle(r, qm, tm, fe, xg, &dt) >= 0 && isfinite(fe[0]) && isfinite(xg[0]));
  tendyn_renderer_destroy(r);
  tendyn_compensator_destroy(c);
  if (failures) printf("%d failures\n", failures);
  else puts("compensator C ABI: ok");
  return failures ? 1 : 0;
}
