/* fg_state.c - FMU states (get/set/free, serialize/deserialize) of an fg_instance.
 *
 * A state is one heap block: a list node (the instance's list of its states, not serialized) followed
 * by the serialized form, header + model data.  The header ends with a 64-bit checksum over every
 * header byte before it and over the model data, written by serialize: a serialized state offered
 * to deserialize is checked whole (tag, sizes, checksum, phase, time) before anything of it is
 * applied.  In memory a state is the instance's own block, used only after it was found in the
 * instance's list: a freed, foreign or made-up handle is refused with an error instead of being read
 * (get and set stay copies, with their tag checked: no checksum to compute per get).
 * fg_state_free_all (from fg_instance_free) frees every state the host did not free itself. */
#include "fg_instance.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#define FG_STATE_MAGIC "SMFMUST"
#define FG_STATE_FORMAT 2u /* 2: the checksum field */
#define FG_TAG_LEN 64
#define HASH_SEED UINT64_C(0xcbf29ce484222325)
#define HASH_MUL UINT64_C(0x9e3779b97f4a7c15) /* odd */

typedef struct {
    char magic[8];
    uint32_t format_version;
    uint32_t phase;
    uint64_t data_size;
    char model_identifier[FG_TAG_LEN];
    char token[FG_TAG_LEN];
    double time;
    uint64_t checksum; /* last: covers the bytes before it and the model data */
} fg_state_header;

struct fg_state_node {
    fg_state_node *next, *prev;
};

#define CHECKSUM_OFFSET offsetof(fg_state_header, checksum)
#define STATE_MASK (FG_PHASE_INSTANTIATED | FG_PHASE_INIT | FG_PHASE_STEP | FG_PHASE_STEP_FAILED | FG_PHASE_TERMINATED)

size_t fg_state_size(void) { return sizeof(fg_state_header) + FG_MODEL_DATA_SIZE; }

static unsigned char *bytes_of(fg_state_node *node) { return (unsigned char *)(node + 1); }

/* One step per 8-byte word w (the last one zero-padded): h = mix((h ^ w) * HASH_MUL), mix(x) = x ^ (x >> 32).
 * For a fixed w the step is a bijection of h (xor, times an odd number modulo 2^64, an invertible
 * xorshift), and for a fixed h it is injective in w: a change within one word (so any one flipped bit)
 * always changes the result.  The shift carries high bits down, so that changes of several words do
 * not cancel by construction; other corruptions pass with a probability of about 2^-64.  A word at a
 * time: a serialize + deserialize of the 23.6 kB plant state (two checksums) took 9.0 us; two checksums
 * of byte-wise FNV-1a took 47 us. */
static uint64_t hash_bytes(uint64_t h, const unsigned char *p, size_t n)
{
    uint64_t w;
    size_t i;
    for (i = 0; i + 8 <= n; i += 8) {
        memcpy(&w, p + i, 8);
        h = (h ^ w) * HASH_MUL;
        h ^= h >> 32;
    }
    if (i < n) {
        w = 0;
        memcpy(&w, p + i, n - i);
        h = (h ^ w) * HASH_MUL;
        h ^= h >> 32;
    }
    return h;
}

static uint64_t checksum_of(const unsigned char *bytes)
{
    return hash_bytes(hash_bytes(HASH_SEED, bytes, CHECKSUM_OFFSET), bytes + sizeof(fg_state_header),
                      FG_MODEL_DATA_SIZE);
}

static void fill_header(const fg_instance *inst, fg_state_header *h)
{
    memset(h, 0, sizeof *h);
    memcpy(h->magic, FG_STATE_MAGIC, sizeof FG_STATE_MAGIC);
    h->format_version = FG_STATE_FORMAT;
    h->phase = (uint32_t)inst->phase;
    h->data_size = (uint64_t)FG_MODEL_DATA_SIZE;
    strncpy(h->model_identifier, FG_MODEL_IDENTIFIER_STRING, FG_TAG_LEN - 1);
    strncpy(h->token, INSTANTIATION_TOKEN, FG_TAG_LEN - 1);
    h->time = inst->time;
}

/* the node of state in the instance's list, compared by address only (never read before found) */
static fg_state_node *find(fg_instance *inst, const void *state)
{
    fg_state_node *n;
    for (n = inst->states; n != NULL; n = n->next)
        if ((const void *)n == state) return n;
    return NULL;
}

/* the node of *state (NULL: a new one, linked into the list), or NULL with a message */
static fg_state_node *node_for(fg_instance *inst, const char *func, void *state)
{
    fg_state_node *n;
    if (state != NULL) {
        n = find(inst, state);
        if (n == NULL)
            fg_log(inst, FG_ERROR, NULL, "%s: the FMU state %p was not made by this instance or was freed", func,
                   state);
        return n;
    }
    n = (fg_state_node *)malloc(sizeof(fg_state_node) + fg_state_size());
    if (n == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: out of memory", func);
        return NULL;
    }
    n->prev = NULL;
    n->next = inst->states;
    if (inst->states != NULL) inst->states->prev = n;
    inst->states = n;
    return n;
}

static void unlink_node(fg_instance *inst, fg_state_node *n)
{
    if (n->prev != NULL) n->prev->next = n->next;
    else inst->states = n->next;
    if (n->next != NULL) n->next->prev = n->prev;
    free(n);
}

/* the known state of a non-NULL handle, or NULL with a message */
static fg_state_node *known(fg_instance *inst, const char *func, const void *state)
{
    fg_state_node *n;
    if (state == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: NULL state", func);
        return NULL;
    }
    n = find(inst, state);
    if (n == NULL)
        fg_log(inst, FG_ERROR, NULL, "%s: the FMU state %p was not made by this instance or was freed", func,
               state);
    return n;
}

fg_status fg_state_get(fg_instance *inst, const char *func, void **state)
{
    fg_state_header h;
    fg_state_node *n;
    unsigned char *b;
    if (!fg_allowed(inst, func, STATE_MASK)) return FG_ERROR;
    if (state == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: NULL state pointer", func);
        return FG_ERROR;
    }
    if ((n = node_for(inst, func, *state)) == NULL) return FG_ERROR;
    b = bytes_of(n);
    fill_header(inst, &h); /* checksum 0: written by serialize */
    memcpy(b, &h, sizeof h);
    memcpy(b + sizeof h, inst->data, FG_MODEL_DATA_SIZE);
    *state = n;
    return FG_OK;
}

/* checks a state of size bytes whole (with its checksum if check_sum); logs why it is refused */
static int blob_ok(fg_instance *inst, const char *func, const unsigned char *buf, size_t size, int check_sum)
{
    fg_state_header h, mine;
    uint64_t sum;
    if (buf == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: NULL state", func);
        return 0;
    }
    if (size < sizeof h) {
        fg_log(inst, FG_ERROR, NULL, "%s: state of %lu bytes is truncated (header is %lu bytes)", func,
               (unsigned long)size, (unsigned long)sizeof h);
        return 0;
    }
    memcpy(&h, buf, sizeof h);
    fill_header(inst, &mine);
    if (memcmp(h.magic, mine.magic, sizeof h.magic) != 0) {
        fg_log(inst, FG_ERROR, NULL, "%s: not a serialized FMU state of this glue (bad magic)", func);
        return 0;
    }
    if (h.format_version != mine.format_version) {
        fg_log(inst, FG_ERROR, NULL, "%s: state format version %lu, expected %lu", func,
               (unsigned long)h.format_version, (unsigned long)mine.format_version);
        return 0;
    }
    /* the whole zero-padded fields must match (a last byte cut off here is still covered by the checksum) */
    h.model_identifier[FG_TAG_LEN - 1] = '\0';
    h.token[FG_TAG_LEN - 1] = '\0';
    if (memcmp(h.model_identifier, mine.model_identifier, FG_TAG_LEN) != 0) {
        fg_log(inst, FG_ERROR, NULL, "%s: state of another model ('%s'), this is '%s'", func, h.model_identifier,
               mine.model_identifier);
        return 0;
    }
    if (memcmp(h.token, mine.token, FG_TAG_LEN) != 0) {
        fg_log(inst, FG_ERROR, NULL, "%s: state of build %s, this is %s", func, h.token, mine.token);
        return 0;
    }
    if (h.data_size == mine.data_size && size < fg_state_size()) {
        fg_log(inst, FG_ERROR, NULL, "%s: state of %lu bytes is truncated (expected %lu)", func, (unsigned long)size,
               (unsigned long)fg_state_size());
        return 0;
    }
    if (h.data_size != mine.data_size || size != fg_state_size()) {
        fg_log(inst, FG_ERROR, NULL, "%s: state of %lu bytes with %lu data bytes, expected %lu and %lu", func,
               (unsigned long)size, (unsigned long)h.data_size, (unsigned long)fg_state_size(),
               (unsigned long)mine.data_size);
        return 0;
    }
    sum = check_sum ? checksum_of(buf) : h.checksum;
    if (sum != h.checksum) {
        fg_log(inst, FG_ERROR, NULL, "%s: corrupted state: checksum %016llx, its content gives %016llx", func,
               (unsigned long long)h.checksum, (unsigned long long)sum);
        return 0;
    }
    if (!(h.phase & STATE_MASK) || (h.phase & (h.phase - 1u)) != 0 || !isfinite(h.time)) {
        fg_log(inst, FG_ERROR, NULL, "%s: state with invalid phase %lu or time", func, (unsigned long)h.phase);
        return 0;
    }
    return 1;
}

fg_status fg_state_set(fg_instance *inst, const char *func, const void *state)
{
    fg_state_header h;
    fg_state_node *n;
    const unsigned char *b;
    if (!fg_allowed(inst, func, STATE_MASK)) return FG_ERROR;
    if ((n = known(inst, func, state)) == NULL) return FG_ERROR;
    b = bytes_of(n);
    if (!blob_ok(inst, func, b, fg_state_size(), 0)) return FG_ERROR;
    memcpy(&h, b, sizeof h);
    memcpy(inst->data, b + sizeof h, FG_MODEL_DATA_SIZE);
    inst->phase = (fg_phase)h.phase;
    inst->time = h.time;
    return FG_OK;
}

fg_status fg_state_free(fg_instance *inst, const char *func, void **state)
{
    fg_state_node *n;
    if (state == NULL || *state == NULL) return FG_OK;
    if ((n = known(inst, func, *state)) == NULL) return FG_ERROR;
    unlink_node(inst, n);
    *state = NULL;
    return FG_OK;
}

void fg_state_free_all(fg_instance *inst)
{
    while (inst->states != NULL) unlink_node(inst, inst->states);
}

fg_status fg_state_serialized_size(fg_instance *inst, const char *func, const void *state, size_t *size)
{
    if (size == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: NULL size argument", func);
        return FG_ERROR;
    }
    if (known(inst, func, state) == NULL) return FG_ERROR;
    *size = fg_state_size();
    return FG_OK;
}

fg_status fg_state_serialize(fg_instance *inst, const char *func, const void *state, unsigned char *buf, size_t size)
{
    fg_state_node *n;
    if (!fg_allowed(inst, func, FG_PHASE_ANY)) return FG_ERROR;
    if (buf == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: NULL buffer", func);
        return FG_ERROR;
    }
    if ((n = known(inst, func, state)) == NULL) return FG_ERROR;
    if (size != fg_state_size()) {
        fg_log(inst, FG_ERROR, NULL, "%s: buffer of %lu bytes, the state has %lu", func, (unsigned long)size,
               (unsigned long)fg_state_size());
        return FG_ERROR;
    }
    {
        uint64_t sum;
        memcpy(buf, bytes_of(n), size);
        sum = checksum_of(buf);
        memcpy(buf + CHECKSUM_OFFSET, &sum, sizeof sum);
    }
    return FG_OK;
}

fg_status fg_state_deserialize(fg_instance *inst, const char *func, const unsigned char *buf, size_t size, void **state)
{
    fg_state_node *n;
    if (!fg_allowed(inst, func, FG_PHASE_ANY)) return FG_ERROR;
    if (state == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: NULL state pointer", func);
        return FG_ERROR;
    }
    if (!blob_ok(inst, func, buf, size, 1)) return FG_ERROR;
    if ((n = node_for(inst, func, *state)) == NULL) return FG_ERROR;
    memcpy(bytes_of(n), buf, size);
    *state = n;
    return FG_OK;
}
