/* lifecycle.c - the transition table (see lifecycle.h). */
#include "lifecycle.h"

#define S(state) STATES(STATE_##state)

static const struct transition transitions[] = {
    {METHOD_INIT, S(NOT_CREATED), STATE_OFF, STATE_NOT_CREATED},
    {METHOD_ON, S(OFF), STATE_ON, STATE_ERROR},
    {METHOD_CYCLE, S(ON), STATE_ON, STATE_ERROR},
    {METHOD_EVALUATE, S(ON), STATE_ON, STATE_ERROR},
    {METHOD_OFF, S(ON), STATE_OFF, STATE_ERROR},
    {METHOD_KILL, S(OFF) | S(ERROR), STATE_KILLED, STATE_KILLED},
    {METHOD_CLEAR, S(ERROR), STATE_OFF, STATE_ERROR},
};

const char *state_name(enum pbo_state state)
{
    static const char *const names[STATE_COUNT] = {"NOT_CREATED", "OFF", "ON", "ERROR", "KILLED"};
    return state < STATE_COUNT ? names[state] : "?";
}

/* "OFF, ERROR": the states of `states`, in declaration order so messages read the same. */
static void add_states(struct text *why, uint8_t states)
{
    bool first = true;
    for (uint32_t state = 0; state < STATE_COUNT; state++) {
        if (states & STATES(state)) {
            text_format(why, first ? "%s" : ", %s", state_name((enum pbo_state)state));
            first = false;
        }
    }
    if (first) {
        text_add(why, "no state");
    }
}

const struct transition *lifecycle_transition(const char *pbo, enum pbo_state state,
                                              enum method method, struct text *why)
{
    uint8_t allowed = 0;

    for (uint32_t i = 0; i < sizeof transitions / sizeof transitions[0]; i++) {
        if (transitions[i].method == method) {
            if (transitions[i].sources & STATES(state)) {
                return &transitions[i];
            }
            allowed = transitions[i].sources;
        }
    }
    text_format(why, "PBO %q: cannot %s from state %s; allowed from ", pbo, method_name(method),
                state_name(state));
    add_states(why, allowed);
    return 0;
}

bool lifecycle_require(const char *pbo, enum pbo_state state, const char *action,
                       uint8_t allowed, struct text *why)
{
    if (allowed & STATES(state)) {
        return true;
    }
    text_format(why, "PBO %q: cannot %s in state %s; allowed in ", pbo, action,
                state_name(state));
    add_states(why, allowed);
    return false;
}
