/* Another vendor's participant on a tandem domain (Eclipse Cyclone DDS, types from idl/tandem.idl by its idlc):
 * the interoperability checks of docs/interop.md. No tandem code.
 *
 *   tandem_cyclone_observer DOMAIN late-join DEPLOYMENT TIMEOUT_S
 *       joins late, reads tandem/process_status (reliable, transient-local) and prints how long the launcher's
 *       status took to arrive and when the launcher's writer had matched (discovery):
 *       launcher_status_ms=<ms> matched_ms=<ms>; exit 0, or 1 if none within the timeout.
 *   tandem_cyclone_observer DOMAIN sensors ARM_ID COUNT TIMEOUT_S
 *       reads tandem/arm_sensors/ARM_ID (best effort) until COUNT samples arrived: samples=<n> first_tick=<k>;
 *       exit 0 if COUNT arrived, 1 otherwise.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "dds/dds.h"
#include "tandem.h"

static double now_ms(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* Whether one of the reader's matched writers belongs to the participant Fast DDS named "launcher/<deployment>". */
static int launcher_matched(dds_entity_t pp, dds_entity_t rd, dds_entity_t parts, const char *deployment) {
  dds_instance_handle_t handles[256];
  const dds_return_t n = dds_get_matched_publications(rd, handles, 256);
  char want[256];
  snprintf(want, sizeof want, "launcher/%s", deployment);
  (void)pp;
  for (dds_return_t i = 0; i < n && i < 256; ++i) {
    dds_builtintopic_endpoint_t *ep = dds_get_matched_publication_data(rd, handles[i]);
    if (ep == NULL) continue;
    void *samples[64] = {0};
    dds_sample_info_t infos[64];
    const int m = dds_read(parts, samples, infos, 64, 64);
    int found = 0;
    for (int k = 0; k < m && !found; ++k) {
      const dds_builtintopic_participant_t *p = samples[k];
      char *name = NULL;
      if (infos[k].valid_data && memcmp(&p->key, &ep->participant_key, sizeof p->key) == 0 &&
          dds_qget_entity_name(p->qos, &name) && name != NULL) {
        found = strcmp(name, want) == 0;
      }
      dds_free(name);
    }
    if (m > 0) dds_return_loan(parts, samples, m);
    dds_builtintopic_free_endpoint(ep);
    if (found) return 1;
  }
  return 0;
}

static int late_join(dds_entity_t pp, const char *deployment, double timeout_s) {
  dds_entity_t topic = dds_create_topic(pp, &tandem_msg_ProcessStatus_desc, "tandem/process_status", NULL, NULL);
  if (topic < 0) return fprintf(stderr, "topic: %s\n", dds_strretcode(-topic)), 2;
  dds_qos_t *qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_durability(qos, DDS_DURABILITY_TRANSIENT_LOCAL);
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 1);
  const double t0 = now_ms();
  dds_entity_t rd = dds_create_reader(pp, topic, qos, NULL);
  dds_delete_qos(qos);
  if (rd < 0) return fprintf(stderr, "reader: %s\n", dds_strretcode(-rd)), 2;
  void *samples[16] = {0};
  dds_sample_info_t infos[16];
  double matched = -1.0;  /* when the launcher's status writer matched this reader (discovery done) */
  dds_entity_t parts = dds_create_reader(pp, DDS_BUILTIN_TOPIC_DCPSPARTICIPANT, NULL, NULL);
  while (now_ms() - t0 < timeout_s * 1e3) {
    if (matched < 0 && launcher_matched(pp, rd, parts, deployment)) matched = now_ms() - t0;
    int n = dds_take(rd, samples, infos, 16, 16);
    for (int i = 0; i < n; ++i) {
      const tandem_msg_ProcessStatus *s = samples[i];
      if (infos[i].valid_data && strcmp(s->process_id, "launcher") == 0 && strcmp(s->deployment, deployment) == 0) {
        printf("launcher_status_ms=%.1f matched_ms=%.1f\n", now_ms() - t0, matched);
        dds_return_loan(rd, samples, n);
        return 0;
      }
    }
    if (n > 0) dds_return_loan(rd, samples, n);
    dds_sleepfor(DDS_MSECS(2));
  }
  printf("launcher_status_ms=none\n");
  return 1;
}

static int sensors(dds_entity_t pp, const char *arm, int count, double timeout_s) {
  char name[256];
  snprintf(name, sizeof name, "tandem/arm_sensors/%s", arm);
  dds_entity_t topic = dds_create_topic(pp, &tandem_msg_ArmSensors_desc, name, NULL, NULL);
  if (topic < 0) return fprintf(stderr, "topic: %s\n", dds_strretcode(-topic)), 2;
  dds_qos_t *qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_BEST_EFFORT, 0);
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 64);
  dds_entity_t rd = dds_create_reader(pp, topic, qos, NULL);
  dds_delete_qos(qos);
  if (rd < 0) return fprintf(stderr, "reader: %s\n", dds_strretcode(-rd)), 2;
  const double t0 = now_ms();
  int got = 0;
  long long first = -1;
  void *samples[64] = {0};
  dds_sample_info_t infos[64];
  while (got < count && now_ms() - t0 < timeout_s * 1e3) {
    int n = dds_take(rd, samples, infos, 64, 64);
    for (int i = 0; i < n; ++i) {
      if (!infos[i].valid_data) continue;
      const tandem_msg_ArmSensors *s = samples[i];
      if (first < 0) first = (long long)s->tick;
      ++got;
    }
    if (n > 0) dds_return_loan(rd, samples, n);
    dds_sleepfor(DDS_MSECS(1));
  }
  printf("samples=%d first_tick=%lld\n", got, first);  /* the last batch may pass COUNT */
  return got >= count ? 0 : 1;
}

int main(int argc, char **argv) {
  if (argc < 3) {
    fprintf(stderr, "usage: %s DOMAIN late-join DEPLOYMENT TIMEOUT_S | DOMAIN sensors ARM_ID COUNT TIMEOUT_S\n", argv[0]);
    return 2;
  }
  dds_entity_t pp = dds_create_participant((dds_domainid_t)atoi(argv[1]), NULL, NULL);
  if (pp < 0) return fprintf(stderr, "participant: %s\n", dds_strretcode(-pp)), 2;
  int rc = 2;
  if (strcmp(argv[2], "late-join") == 0 && argc == 5) {
    rc = late_join(pp, argv[3], atof(argv[4]));
  } else if (strcmp(argv[2], "sensors") == 0 && argc == 6) {
    rc = sensors(pp, argv[3], atoi(argv[4]), atof(argv[5]));
  } else {
    fprintf(stderr, "unknown mode or arguments\n");
  }
  dds_delete(pp);
  return rc;
}
