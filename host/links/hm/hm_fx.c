/* Effect mode on a HapticMaster: the controller's effect sets as the device's effects; see hm_fx.h. */
#include "hm_fx.h"

#include <string.h>

static const char create_text[] =
	"create spring swell_pull;create spring swell_push;create damper swell_damp;"
	"create biasforce swell_weight;"
	"set swell_pull direction [0,0,1];set swell_pull deadband 1;set swell_pull dampfactor 0;"
	"set swell_push direction [0,0,1];set swell_push deadband 1;set swell_push dampfactor 0;";

static const char enable_text[] =
	";set swell_pull enable;set swell_push enable;set swell_damp enable;set swell_weight enable";

void hm_fx_init(struct hm_fx *x, struct hm_client *c, uint32_t fresh_ticks)
{
	memset(x, 0, sizeof(*x));
	x->fresh_ticks = fresh_ticks ? fresh_ticks : HM_FX_FRESH_TICKS;
	x->session = c->st.startups;
	c->cleanup = HMC_FX_REMOVE;
}

int hm_fx_msg(struct hm_fx *x, const struct hm_client *c, const struct swell_msg *m)
{
	struct swell_effect set;
	const int r = swell_effect_recv(&x->rx, m, &set);

	if (r < 0)
		return 0;
	if (r == 1) {
		x->st.sets++;
		x->st.replaced += x->unsent != 0;
		x->set = set;
		x->set_tick = c->tick;
		x->have = x->unsent = 1;
	}
	return 1;
}

size_t hm_fx_values(const struct swell_effect *e, char *buf, size_t cap)
{
	char pull[24], push[24], uw[24], k[24], nk[24], fmax[24], b[24], bias[24];
	int n;

	hm_client_fmt_fixed(pull, sizeof(pull), (int64_t)e->surface_10um + HM_FX_DEADBAND_10UM, 5);
	hm_client_fmt_fixed(push, sizeof(push), (int64_t)e->surface_10um - e->h_10um + HM_FX_DEADBAND_10UM, 5);
	hm_client_fmt_fixed(uw, sizeof(uw), e->uw_100ums, 4);
	hm_client_fmt_fixed(k, sizeof(k), e->k_10mN_m, 2);
	hm_client_fmt_fixed(nk, sizeof(nk), -(int64_t)e->k_10mN_m, 2);
	hm_client_fmt_fixed(fmax, sizeof(fmax), e->fmax_cN, 2);
	hm_client_fmt_fixed(b, sizeof(b), e->b_10mNs_m, 2);
	hm_client_fmt_fixed(bias, sizeof(bias), e->bias_mN, 3);
	n = snprintf(buf, cap,
		     "set swell_pull pos [0,0,%s];set swell_pull vel [0,0,%s];set swell_pull stiffness %s;"
		     "set swell_pull maxforce %s;set swell_push pos [0,0,%s];set swell_push vel [0,0,%s];"
		     "set swell_push stiffness %s;set swell_push maxforce %s;set swell_damp dampcoef [0,0,%s];"
		     "set swell_damp vel [0,0,%s];set swell_weight force [0,0,%s]",
		     pull, uw, k, fmax, push, uw, nk, fmax, b, uw, bias);
	return n < 0 || (size_t)n >= cap ? 0 : (size_t)n;
}

/* The set goes out: as the creation request (the first of a session) or as the next tick's update;
 * when there is no room it stays unsent, tried again next tick. */
static void send_set(struct hm_fx *x, struct hm_client *c)
{
	char text[HMC_TEXT_MAX];
	size_t n = sizeof(create_text) - 1;
	int sent;

	if (x->live) {
		sent = hm_fx_values(&x->set, text, sizeof(text)) > 0 && hm_client_set_extra(c, text) == 0;
	} else {
		memcpy(text, create_text, n);
		n += hm_fx_values(&x->set, text + n, sizeof(text) - n - sizeof(enable_text));
		memcpy(text + n, enable_text, sizeof(enable_text));
		sent = n > sizeof(create_text) - 1 && hm_client_request(c, text, 1) == 0;
	}
	if (!sent) {
		x->st.unsent++;
		return;
	}
	x->st.updates += x->live != 0;
	x->st.creations += !x->live;
	if (!x->live)
		x->session = c->st.startups;
	x->live = 1;
	x->unsent = 0;
}

void hm_fx_tick(struct hm_fx *x, struct hm_client *c, int enable, int trusted)
{
	if (x->live && c->st.startups != x->session) {
		x->live = 0; /* a new session: its start-up removed them */
		x->unsent = x->have;
	}
	if (x->have && c->tick - x->set_tick > x->fresh_ticks) {
		x->st.stale++;
		x->have = x->unsent = 0;
	}
	if (!enable)
		x->have = x->unsent = 0; /* a disabled command drops the set: a new one is needed */
	if (x->have && trusted && c->phase == HMC_RUNNING) {
		if (x->unsent)
			send_set(x, c);
		return;
	}
	if (x->live && hm_client_fd(c) >= 0) {
		hm_client_set_extra(c, ""); /* an update not sent yet must not follow the removal */
		if (hm_client_request(c, HMC_FX_REMOVE, 0) < 0) {
			x->st.unsent++;
			return; /* tried again next tick */
		}
		x->live = 0;
		x->st.stops++;
	}
	x->unsent = x->have; /* what is kept goes again once the trust is back */
}

void hm_fx_report(const struct hm_fx *x, FILE *f)
{
	const struct hm_fx_stats *s = &x->st;

	fprintf(f,
		"  hm effects      %u sets taken, %u sent (%u created the effects), %u replaced before sending, %u "
		"went stale (%u ticks), %u removals, %u requests without room\n",
		s->sets, s->updates + s->creations, s->creations, s->replaced, s->stale, x->fresh_ticks, s->stops,
		s->unsent);
}
