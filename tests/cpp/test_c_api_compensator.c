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
  double e[4];
  EXPECT(tendyn_compensator_passivity(c, e, NULL, NULL, NULL, NULL) == TENDYN_INVALID_MODEL); /* no section */
  EXPECT(tendyn_compensator_passivity(NULL, e, NULL, NULL, NULL, NULL) == TENDYN_NULL_ARGUMENT);
  EXPECT(tendyn_compensator_tracking(c, NULL, NULL, NULL) == TENDYN_INVALID_MODEL); /* no section either */
  tendyn_compensator_destroy(c);

  /* The same file with an optional passivity section appended: loads, observes and damps at k = 1.5. */
  {
    static char text[1 << 16];
    FILE* in = fopen(argv[1], "r");
    EXPECT(in != NULL);
    if (!in) return 1;
    size_t len = fread(text, 1, sizeof text - 512, in);
    fclose(in);
    text[len] = 0;
    char* k = strstr(text, "underestimation ");
    EXPECT(k != NULL);
    if (k) memcpy(k + 16, "1.5", 3);    /* over-compensate (the original value has >= 3 characters) */
    strcat(text, "section passivity 1\nenabled 1\ndissipation_coulomb 0.001 0.001 0.001 0.001\n"
                 "dissipation_viscous 0 0 0 0\nreserve 0\ndamping_max 0.05\n"
                 "section tracking 1\nenabled 1\nforgetting 0.999\nvelocity_min 1\nacceleration_max 1000\n"
                 "scale_min 0.2\nscale_max 3\ncovariance_max 1\n");
    const char* path = "test_c_api_passivity.comp";
    FILE* out = fopen(path, "w");
    EXPECT(out != NULL);
    if (!out) return 1;
    fputs(text, out);
    fclose(out);
    tendyn_compensator* cp = NULL;
    EXPECT(tendyn_compensator_load(path, "L-EXOS", &cp, message, sizeof message) == TENDYN_OK);
    if (!cp) {
      printf("%s\n", message);
      return 1;
    }
    double damping[4] = {0}, torque[4], injected[4], budget[4], max_damping = 0.0;
    for (int step = 0; step < 2000; ++step) {
      for (int i = 0; i < 4; ++i) qm[i] = 0.1 * (i + 1) + 0.02 * step * (i + 1) * 1e-1; /* 2-8 rad/s ramps */
      EXPECT(tendyn_compensator_cycle(cp, qm, tj, tm, NULL) >= 0);
      EXPECT(tendyn_compensator_passivity(cp, e, damping, torque, injected, budget) == TENDYN_OK);
      for (int i = 0; i < 4; ++i)
        if (damping[i] > max_damping) max_damping = damping[i];
    }
    printf("passivity: E = %g J, injected %g J, budget %g J, max damping %g N m s/rad\n", e[0], injected[0],
           budget[0], max_damping);
    double sc[4], sv[4];
    long updates[4] = {0, 0, 0, 0};
    EXPECT(tendyn_compensator_tracking(cp, sc, sv, updates) == TENDYN_OK);
    printf("tracking: %ld updates, scales %g %g\n", updates[0], sc[0], sv[0]);
    EXPECT(updates[0] > 0 && isfinite(sc[0]) && sc[0] >= 0.2 && sc[0] <= 3.0);
    EXPECT(tendyn_compensator_set_tracking_active(cp, 0) == TENDYN_OK);
    EXPECT(tendyn_compensator_cycle(cp, qm, tj, tm, NULL) >= 0);
    long after[4];
    EXPECT(tendyn_compensator_tracking(cp, NULL, NULL, after) == TENDYN_OK && after[0] == updates[0]);
    EXPECT(max_damping > 0.0 && max_damping <= 0.05);
    tendyn_compensator_destroy(cp);
    remove(path);
  }
  if (failures) printf("%d failures\n", failures);
  else puts("compensator C ABI: ok");
  return failures ? 1 : 0;
}
