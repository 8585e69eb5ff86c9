/* string.find, string.match, string.gmatch and string.gsub for scenes, with a pattern matcher
 * that counts its steps.
 *
 * Why. Lua's matcher backtracks: string.find(string.rep("a", 40), string.rep("a*", 40) .. "b")
 * tries about 40^40 ways inside one C call, and a pattern that costs O(n) at each of n starting
 * points costs O(n^2) on a long subject; the instruction hook never runs inside a C call, so the
 * scene's limits could not stop either. A bound on the pattern's shape would be fragile (the cost
 * depends on the subject too); counting the work is not.
 *
 * Design. This is a matcher of the Lua 5.4 pattern language (manual §6.4.1: single-character
 * classes ., %a %c %d %g %l %p %s %u %w %x and their upper-case complements, %x escapes, [sets]
 * with ranges and classes, [^...]; items with *, +, - and ?; captures and position captures ();
 * %1-%9 back-references; %b balances; %f frontiers; ^ and $ anchors), written as a backtracking
 * recursive matcher like Lua's own, so results, captures and error messages are the same (the
 * tests compare it with Lua's string library on a few hundred patterns). Every step — one pattern
 * item tried at one position, one character examined by an expansion or a %b scan, one starting
 * position — counts 1; every STEP_CHUNK steps the count is charged to the scene's budget
 * (sc_charge: the instruction limit and the wall clock), so a match can take at most what the
 * budget has left, and a limit hit inside a match cannot be caught, as everywhere in the sandbox.
 * The matcher holds no memory of its own (captures live in the C frame, results in Lua buffers),
 * so the error can unwind through it at any step. Recursion depth is capped at MAX_DEPTH
 * ("pattern too complex"), as in Lua. */
#define _GNU_SOURCE /* memmem */
#include <ctype.h>
#include <string.h>

#include <lua5.4/lauxlib.h>
#include <lua5.4/lua.h>
#include <lua5.4/lualib.h>

#include "app/scene/scene_internal.h"

#define ESC '%'
#define MAX_CAPTURES 32 /* as LUA_MAXCAPTURES */
#define MAX_DEPTH 200
#define STEP_CHUNK 4096
#define CAP_UNFINISHED (-1)
#define CAP_POSITION (-2)
#define SPECIALS "^$*+?.([%-"

typedef struct matcher {
    lua_State *L;
    const char *what;                 /* "string.find", ... for the limit's message */
    const char *src, *src_end;        /* the subject */
    const char *pat_end;              /* the pattern's end */
    int depth;                        /* recursion left */
    int ncap;                         /* captures opened so far */
    unsigned steps;                   /* steps not yet charged */
    struct {
        const char *start;
        ptrdiff_t len;                /* or CAP_UNFINISHED / CAP_POSITION */
    } cap[MAX_CAPTURES];
} matcher;

static void step(matcher *m) {
    if (++m->steps == STEP_CHUNK) {
        m->steps = 0;
        sc_charge(m->L, m->what, STEP_CHUNK);
    }
}

static void reset(matcher *m) {
    m->ncap = 0;
    m->depth = MAX_DEPTH;
}

static void matcher_init(matcher *m, lua_State *L, const char *what, const char *s, size_t ls, const char *p,
                         size_t lp) {
    m->L = L;
    m->what = what;
    m->src = s;
    m->src_end = s + ls;
    m->pat_end = p + lp;
    m->steps = 0;
    reset(m);
}

/* Charges the steps left over (at the end of a library call). */
static void settle(matcher *m) {
    sc_charge(m->L, m->what, m->steps);
    m->steps = 0;
}

/* Does character c belong to class letter cl (%a, %d, ...; upper case: the complement)? */
static int in_class(int c, int cl) {
    int r;
    switch (tolower(cl)) {
    case 'a': r = isalpha(c); break;
    case 'c': r = iscntrl(c); break;
    case 'd': r = isdigit(c); break;
    case 'g': r = isgraph(c); break;
    case 'l': r = islower(c); break;
    case 'p': r = ispunct(c); break;
    case 's': r = isspace(c); break;
    case 'u': r = isupper(c); break;
    case 'w': r = isalnum(c); break;
    case 'x': r = isxdigit(c); break;
    default: return cl == c; /* %. is a literal */
    }
    r = r != 0;
    return isupper(cl) ? !r : r;
}

/* Is c in the set that opens at p ('[') and closes at close (its ']')? */
static int in_set(int c, const char *p, const char *close) {
    int want = 1;
    p++;
    if (*p == '^') {
        want = 0;
        p++;
    }
    for (; p < close; p++) {
        if (*p == ESC) {
            p++;
            if (in_class(c, (unsigned char)*p)) return want;
        } else if (p[1] == '-' && p + 2 < close) {
            if ((unsigned char)p[0] <= c && c <= (unsigned char)p[2]) return want;
            p += 2;
        } else if ((unsigned char)*p == c) {
            return want;
        }
    }
    return !want;
}

/* The end of the single-character class that starts at p. */
static const char *class_end(matcher *m, const char *p) {
    char c = *p++;
    if (c == ESC) {
        if (p >= m->pat_end) luaL_error(m->L, "malformed pattern (ends with '%%')");
        return p + 1;
    }
    if (c == '[') {
        if (p < m->pat_end && *p == '^') p++;
        do { /* the first character is in the set even if it is ']' */
            if (p >= m->pat_end) luaL_error(m->L, "malformed pattern (missing ']')");
            if (*p++ == ESC && p < m->pat_end) p++;
        } while (p >= m->pat_end || *p != ']');
        return p + 1;
    }
    return p;
}

/* Does the subject character at s match the class p..ep? */
static int single(matcher *m, const char *s, const char *p, const char *ep) {
    if (s >= m->src_end) return 0;
    int c = (unsigned char)*s;
    switch (*p) {
    case '.': return 1;
    case ESC: return in_class(c, (unsigned char)p[1]);
    case '[': return in_set(c, p, ep - 1);
    default: return (unsigned char)*p == c;
    }
}

static const char *match(matcher *m, const char *s, const char *p);

/* item* and item+ (greedy): the longest run first, then shorter ones. */
static const char *expand_max(matcher *m, const char *s, const char *p, const char *ep) {
    ptrdiff_t n = 0;
    while (single(m, s + n, p, ep)) {
        step(m);
        n++;
    }
    for (; n >= 0; n--) {
        step(m);
        const char *r = match(m, s + n, ep + 1);
        if (r) return r;
    }
    return NULL;
}

/* item- (lazy): the shortest run first. */
static const char *expand_min(matcher *m, const char *s, const char *p, const char *ep) {
    for (;;) {
        step(m);
        const char *r = match(m, s, ep + 1);
        if (r) return r;
        if (!single(m, s, p, ep)) return NULL;
        s++;
    }
}

static const char *open_capture(matcher *m, const char *s, const char *p, ptrdiff_t kind) {
    if (m->ncap >= MAX_CAPTURES) luaL_error(m->L, "too many captures");
    m->cap[m->ncap].start = s;
    m->cap[m->ncap].len = kind;
    m->ncap++;
    const char *r = match(m, s, p);
    if (!r) m->ncap--;
    return r;
}

static const char *close_capture(matcher *m, const char *s, const char *p) {
    int i = m->ncap - 1;
    while (i >= 0 && m->cap[i].len != CAP_UNFINISHED) i--;
    if (i < 0) luaL_error(m->L, "invalid pattern capture");
    m->cap[i].len = s - m->cap[i].start;
    const char *r = match(m, s, p);
    if (!r) m->cap[i].len = CAP_UNFINISHED;
    return r;
}

/* %1..%9: the text of an earlier, closed capture. */
static const char *back_reference(matcher *m, const char *s, int digit) {
    int i = digit - '1';
    if (i < 0 || i >= m->ncap || m->cap[i].len == CAP_UNFINISHED)
        luaL_error(m->L, "invalid capture index %%%d", i + 1);
    ptrdiff_t len = m->cap[i].len;
    if (len < 0 || m->src_end - s < len || memcmp(m->cap[i].start, s, (size_t)len) != 0) return NULL;
    return s + len;
}

/* %bxy at p (pointing at x): a balanced run from x to its y. */
static const char *balance(matcher *m, const char *s, const char *p) {
    if (p + 1 >= m->pat_end) luaL_error(m->L, "malformed pattern (missing arguments to '%%b')");
    if (s >= m->src_end || *s != p[0]) return NULL;
    int open = 1;
    while (++s < m->src_end) {
        step(m);
        if (*s == p[1]) {
            if (--open == 0) return s + 1;
        } else if (*s == p[0]) {
            open++;
        }
    }
    return NULL;
}

/* %f[set] at p (pointing at '['): the previous character is not in the set and the next one is. */
static int frontier(matcher *m, const char *s, const char *p, const char **ep) {
    if (p >= m->pat_end || *p != '[') luaL_error(m->L, "missing '[' after '%%f' in pattern");
    *ep = class_end(m, p);
    int prev = s == m->src ? 0 : (unsigned char)s[-1];
    int next = s < m->src_end ? (unsigned char)*s : 0;
    return !in_set(prev, p, *ep - 1) && in_set(next, p, *ep - 1);
}

/* Matches the pattern from p at subject position s: the end of the match, or NULL. Iterates over
 * the pattern's items while they need no backtracking; recurses where they do. */
static const char *match(matcher *m, const char *s, const char *p) {
    if (m->depth-- == 0) luaL_error(m->L, "pattern too complex");
    while (s && p < m->pat_end) {
        step(m);
        const char *ep;
        if (*p == '(') {
            s = p + 1 < m->pat_end && p[1] == ')' ? open_capture(m, s, p + 2, CAP_POSITION)
                                                  : open_capture(m, s, p + 1, CAP_UNFINISHED);
            break;
        }
        if (*p == ')') {
            s = close_capture(m, s, p + 1);
            break;
        }
        if (*p == '$' && p + 1 == m->pat_end) {
            s = s == m->src_end ? s : NULL;
            break;
        }
        if (*p == ESC && p + 1 < m->pat_end) {
            char c = p[1];
            if (c == 'b') {
                s = balance(m, s, p + 2);
                p += 4;
                continue;
            }
            if (c == 'f') {
                if (!frontier(m, s, p + 2, &ep)) s = NULL;
                p = ep;
                continue;
            }
            if (c >= '0' && c <= '9') {
                s = back_reference(m, s, c);
                p += 2;
                continue;
            }
        }
        ep = class_end(m, p);
        char q = ep < m->pat_end ? *ep : 0;
        if (!single(m, s, p, ep)) {
            if (q == '*' || q == '?' || q == '-') p = ep + 1; /* zero repetitions are fine */
            else s = NULL;
            continue;
        }
        if (q == '?') {
            const char *r = match(m, s + 1, ep + 1);
            if (r) {
                s = r;
                break;
            }
            p = ep + 1;
        } else if (q == '+' || q == '*') {
            s = expand_max(m, q == '+' ? s + 1 : s, p, ep);
            break;
        } else if (q == '-') {
            s = expand_min(m, s, p, ep);
            break;
        } else {
            s++;
            p = ep;
        }
    }
    m->depth++;
    return s;
}

/* Pushes capture i of the match s..e (the whole match for i = 0 when there are no captures). */
static void push_capture(matcher *m, int i, const char *s, const char *e) {
    if (i >= m->ncap) {
        if (i != 0) luaL_error(m->L, "invalid capture index %%%d", i + 1);
        lua_pushlstring(m->L, s, (size_t)(e - s));
        return;
    }
    ptrdiff_t len = m->cap[i].len;
    if (len == CAP_UNFINISHED) luaL_error(m->L, "unfinished capture");
    if (len == CAP_POSITION) lua_pushinteger(m->L, (lua_Integer)(m->cap[i].start - m->src) + 1);
    else lua_pushlstring(m->L, m->cap[i].start, (size_t)len);
}

/* Pushes all captures (or the whole match if s is not NULL and there are none); their number. */
static int push_captures(matcher *m, const char *s, const char *e) {
    int n = m->ncap == 0 && s ? 1 : m->ncap;
    luaL_checkstack(m->L, n, "too many captures");
    for (int i = 0; i < n; i++) push_capture(m, i, s, e);
    return n;
}

/* A 1-based start position (negative: from the end) as an offset in 0..len+1. */
static size_t start_offset(lua_Integer pos, size_t len) {
    if (pos > 0) return (size_t)pos - 1;
    if (pos == 0 || pos < -(lua_Integer)len) return 0;
    return len + (size_t)pos;
}

static int has_specials(const char *p, size_t lp) {
    for (size_t i = 0; i < lp; i++)
        if (p[i] && strchr(SPECIALS, p[i])) return 1;
    return 0;
}

/* find (find = 1) and match (find = 0). */
static int find_or_match(lua_State *L, int find) {
    size_t ls, lp;
    const char *s = luaL_checklstring(L, 1, &ls);
    const char *p = luaL_checklstring(L, 2, &lp);
    size_t init = start_offset(luaL_optinteger(L, 3, 1), ls);
    if (init > ls) {
        luaL_pushfail(L);
        return 1;
    }
    const char *what = find ? "string.find" : "string.match";
    if (find && (lua_toboolean(L, 4) || !has_specials(p, lp))) { /* a plain search */
        sc_charge(L, what, (long long)((ls - init) / 16));
        const char *hit = lp == 0 ? s + init : memmem(s + init, ls - init, p, lp);
        if (hit) {
            lua_pushinteger(L, (lua_Integer)(hit - s) + 1);
            lua_pushinteger(L, (lua_Integer)(hit - s + (ptrdiff_t)lp));
            return 2;
        }
        luaL_pushfail(L);
        return 1;
    }
    matcher m;
    int anchored = lp > 0 && *p == '^';
    if (anchored) p++, lp--;
    matcher_init(&m, L, what, s, ls, p, lp);
    const char *at = s + init;
    do {
        reset(&m);
        const char *e = match(&m, at, p);
        if (e) {
            settle(&m);
            if (!find) return push_captures(&m, at, e);
            lua_pushinteger(L, (lua_Integer)(at - s) + 1);
            lua_pushinteger(L, (lua_Integer)(e - s));
            return push_captures(&m, NULL, NULL) + 2;
        }
        step(&m);
    } while (at++ < m.src_end && !anchored);
    settle(&m);
    luaL_pushfail(L);
    return 1;
}

static int scene_find(lua_State *L) { return find_or_match(L, 1); }
static int scene_match(lua_State *L) { return find_or_match(L, 0); }

/* The gmatch iterator: upvalues subject, pattern, state (a userdata: next offset, offset where the
 * last match ended or -1). */
typedef struct gmatch_state {
    size_t next;
    ptrdiff_t last;
} gmatch_state;

static int gmatch_next(lua_State *L) {
    size_t ls, lp;
    const char *s = lua_tolstring(L, lua_upvalueindex(1), &ls);
    const char *p = lua_tolstring(L, lua_upvalueindex(2), &lp);
    gmatch_state *g = lua_touserdata(L, lua_upvalueindex(3));
    matcher m;
    matcher_init(&m, L, "string.gmatch", s, ls, p, lp);
    for (const char *at = s + g->next; at <= m.src_end; at++) {
        reset(&m);
        const char *e = match(&m, at, p);
        if (e && e - s != g->last) {
            g->next = (size_t)(e - s);
            g->last = e - s;
            settle(&m);
            return push_captures(&m, at, e);
        }
        step(&m);
    }
    settle(&m);
    return 0;
}

static int scene_gmatch(lua_State *L) {
    size_t ls;
    luaL_checklstring(L, 1, &ls);
    luaL_checkstring(L, 2);
    size_t init = start_offset(luaL_optinteger(L, 3, 1), ls);
    lua_settop(L, 2);
    gmatch_state *g = lua_newuserdatauv(L, sizeof *g, 0);
    g->next = init > ls ? ls + 1 : init;
    g->last = -1;
    lua_pushcclosure(L, gmatch_next, 3);
    return 1;
}

/* gsub's replacement string (argument 3) for the match s..e: %0-%9 and %%. */
static void add_replacement_string(matcher *m, luaL_Buffer *b, const char *s, const char *e) {
    lua_State *L = m->L;
    size_t l;
    const char *r = lua_tolstring(L, 3, &l), *end = r + l;
    while (r < end) {
        const char *esc = memchr(r, ESC, (size_t)(end - r));
        if (!esc) {
            luaL_addlstring(b, r, (size_t)(end - r));
            break;
        }
        luaL_addlstring(b, r, (size_t)(esc - r));
        char c = esc + 1 < end ? esc[1] : 0;
        if (c == ESC) {
            luaL_addchar(b, ESC);
        } else if (c == '0') {
            luaL_addlstring(b, s, (size_t)(e - s));
        } else if (isdigit((unsigned char)c)) {
            push_capture(m, c - '1', s, e);
            luaL_tolstring(L, -1, NULL);
            lua_remove(L, -2);
            luaL_addvalue(b);
        } else {
            luaL_error(L, "invalid use of '%c' in replacement string", ESC);
        }
        r = esc + 2;
    }
}

/* Appends the replacement of the match s..e (argument 3: string, table or function; false or nil
 * from a table or function keeps the match). */
static void add_replacement(matcher *m, luaL_Buffer *b, const char *s, const char *e, int kind) {
    lua_State *L = m->L;
    if (kind == LUA_TFUNCTION) {
        lua_pushvalue(L, 3);
        lua_call(L, push_captures(m, s, e), 1);
    } else if (kind == LUA_TTABLE) {
        push_capture(m, 0, s, e);
        lua_gettable(L, 3);
    } else {
        add_replacement_string(m, b, s, e);
        return;
    }
    if (!lua_toboolean(L, -1)) {
        lua_pop(L, 1);
        luaL_addlstring(b, s, (size_t)(e - s));
    } else if (!lua_isstring(L, -1)) {
        luaL_error(L, "invalid replacement value (a %s)", luaL_typename(L, -1));
    } else {
        luaL_addvalue(b);
    }
}

static int scene_gsub(lua_State *L) {
    size_t ls, lp;
    const char *src = luaL_checklstring(L, 1, &ls);
    const char *p = luaL_checklstring(L, 2, &lp);
    int kind = lua_type(L, 3);
    lua_Integer max_n = luaL_optinteger(L, 4, (lua_Integer)ls + 1);
    luaL_argexpected(L, kind == LUA_TNUMBER || kind == LUA_TSTRING || kind == LUA_TFUNCTION || kind == LUA_TTABLE, 3,
                     "string/function/table");
    int anchored = lp > 0 && *p == '^';
    if (anchored) p++, lp--;
    luaL_Buffer b;
    luaL_buffinit(L, &b);
    matcher m;
    matcher_init(&m, L, "string.gsub", src, ls, p, lp);
    const char *last = NULL;
    lua_Integer n = 0;
    while (n < max_n) {
        reset(&m);
        step(&m);
        const char *e = match(&m, src, p);
        if (e && e != last) {
            n++;
            add_replacement(&m, &b, src, e, kind);
            src = last = e;
        } else if (src < m.src_end) {
            luaL_addchar(&b, *src++);
        } else {
            break;
        }
        if (anchored) break;
    }
    settle(&m);
    luaL_addlstring(&b, src, (size_t)(m.src_end - src));
    luaL_pushresult(&b);
    lua_pushinteger(L, n);
    return 2;
}

void sc_open_patterns(lua_State *L) {
    const luaL_Reg fns[] = {{"find", scene_find}, {"match", scene_match}, {"gmatch", scene_gmatch},
                            {"gsub", scene_gsub}, {NULL, NULL}};
    lua_getglobal(L, LUA_STRLIBNAME);
    luaL_setfuncs(L, fns, 0);
    lua_pop(L, 1);
}
