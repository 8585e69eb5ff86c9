/* The scene sandbox: a fresh lua_State per scene with
 *   - a counting allocator: the memory limit (SCENE_MEM_LIMIT, 256 MB of Lua memory), and the
 *     memory a scene allocates counted as work (bytes / 256), so that a loop of few instructions
 *     that copies much (big string concatenations) meets the limits as soon as a loop that
 *     computes;
 *   - a budget of work: the count hook adds HOOK_STEP every HOOK_STEP Lua instructions, and the
 *     library functions that can work long inside one call (string.rep, the pattern functions,
 *     table.sort/concat/move/insert/remove/unpack, print, string.format/upper/lower/reverse) add
 *     what the call costs (bounded.c, pattern.c) through sc_charge;
 *   - a time limit beside it, checked by the same hook and charges every CLOCK_EVERY units of
 *     work: CPU seconds of the calling thread (wall-clock time would make the limit depend on the
 *     machine's load: on a loaded 2-core machine a scene took 10.3 s of wall clock for 1.2 s of
 *     CPU), and WALL_FACTOR times as many seconds of wall clock (a scene blocked outside the CPU,
 *     e.g. printing into a full pipe);
 *   - only the safe libraries (base without dofile/loadfile/load, math, string without dump,
 *     pack and unpack, table, utf8; no io, os, package, debug, coroutine), the string metatable
 *     hidden from getmetatable, setmetatable without __gc, collectgarbage("count"/"collect") only.
 *
 * Why a limit cannot be caught. When the budget or the clock runs out, the scene is "tripped":
 * the hook then runs at every instruction and raises the limit's message each time, and the only
 * functions that catch errors, pcall and xpcall, are replaced by versions that re-raise the limit's
 * message once the scene is tripped. xpcall's message handler would run inside the hook (where Lua
 * disables hooks, so an endless handler could never be stopped): the replacement wraps the
 * handler in a guard that returns the message untouched, without calling the scene's handler, once
 * the scene is tripped. Finalizers (__gc) run with hooks off too, so setmetatable refuses them; to-be-
 * closed variables' __close run with hooks on and fail at their first instruction. So after a trip
 * no scene code runs more than one instruction, and the error reaches the loader's lua_pcall. */
#define _POSIX_C_SOURCE 200809L
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <lua5.4/lauxlib.h>
#include <lua5.4/lua.h>
#include <lua5.4/lualib.h>

#include "app/scene/scene_internal.h"

#define HOOK_STEP 1000    /* the count hook runs every HOOK_STEP instructions */
#define CLOCK_EVERY 16000 /* units of work between two looks at the clocks */
#define WALL_FACTOR 10    /* wall-clock limit = WALL_FACTOR x the CPU-time limit */

sc_limits sc_scene_limits = {SCENE_INSN_LIMIT, MOTION_INSN_LIMIT, SCENE_TIME_LIMIT, MOTION_TIME_LIMIT, SCENE_MEM_LIMIT};

sm_scene *sc_scene_of(lua_State *L) { return *(sm_scene **)lua_getextraspace(L); }

static double clock_seconds(clockid_t id) {
    struct timespec ts;
    if (clock_gettime(id, &ts) != 0) return 0;
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* 0 while the budget's time lasts, else 1 (CPU time) or 2 (wall clock); looks at the clocks only
 * every CLOCK_EVERY units of work. */
static int out_of_time(sm_scene *s) {
    if (s->insn < s->next_clock) return 0;
    s->next_clock = s->insn + CLOCK_EVERY;
    if (clock_seconds(CLOCK_THREAD_CPUTIME_ID) - s->cpu_start > s->time_limit) return 1;
    if (clock_seconds(CLOCK_MONOTONIC) - s->wall_start > WALL_FACTOR * s->time_limit) return 2;
    return 0;
}

static void insn_hook(lua_State *L, lua_Debug *ar);

/* The Lua allocator: refuses growth past the memory limit, and charges growth to the budget
 * (bytes / 256: a concatenation of big strings is few instructions but much work); when the
 * budget is due for a look at the clocks it makes the hook run at the very next instruction. */
static void *scene_alloc(void *ud, void *ptr, size_t osize, size_t nsize) {
    sm_scene *s = ud;
    size_t old = ptr ? osize : 0;
    if (nsize == 0) {
        free(ptr);
        s->mem -= old;
        return NULL;
    }
    if (nsize > old && s->mem + (nsize - old) > s->mem_limit) {
        s->mem_hit = 1;
        return NULL;
    }
    void *q = realloc(ptr, nsize);
    if (!q) return nsize <= old ? ptr : NULL; /* Lua assumes shrinking never fails */
    s->mem = s->mem - old + nsize;
    if (nsize > old && s->hooks_on) {
        s->insn += (long long)((nsize - old) / 256);
        if (s->insn >= s->next_clock && s->hook_every != 1) {
            s->hook_every = 1; /* lua_sethook only sets the hook's fields: safe here */
            lua_sethook(s->L, insn_hook, LUA_MASKCOUNT, 1);
        }
    }
    return q;
}

/* Marks the scene tripped with msg (prefixed by where, the position of the scene code that ran
 * into the limit) and raises it; every later instruction raises it again. */
static void trip(lua_State *L, sm_scene *s, const char *where, const char *msg) {
    if (!s->tripped) {
        s->tripped = 1;
        snprintf(s->trip_msg, sizeof s->trip_msg, "%s%s", where, msg);
        s->hook_every = 1;
        lua_sethook(L, insn_hook, LUA_MASKCOUNT, 1);
    }
    lua_pushstring(L, s->trip_msg);
    lua_error(L);
}

static void over_time(lua_State *L, sm_scene *s, const char *where, int which) {
    char msg[256];
    snprintf(msg, sizeof msg, "time limit exceeded (%g s of %s for %s): an endless loop or too much work?",
             which == 1 ? s->time_limit : WALL_FACTOR * s->time_limit, which == 1 ? "CPU time" : "wall-clock time",
             s->budget_what);
    trip(L, s, where, msg);
}

static void insn_hook(lua_State *L, lua_Debug *ar) {
    (void)ar;
    sm_scene *s = sc_scene_of(L);
    if (s->tripped) trip(L, s, "", "");
    s->insn += s->hook_every;
    if (s->hook_every != HOOK_STEP) { /* called early by the allocator: back to the usual pace */
        s->hook_every = HOOK_STEP;
        lua_sethook(L, insn_hook, LUA_MASKCOUNT, HOOK_STEP);
    }
    int late = s->insn <= s->insn_limit ? out_of_time(s) : 0;
    if (s->insn <= s->insn_limit && !late) return;
    luaL_where(L, 0); /* in a hook, level 0 is the interrupted function */
    const char *where = lua_tostring(L, -1);
    if (late) over_time(L, s, where, late);
    char msg[160];
    snprintf(msg, sizeof msg, "instruction limit exceeded (%d million Lua instructions): an endless loop?",
             (int)(s->insn_limit / 1000000));
    trip(L, s, where, msg);
}

void sc_charge(lua_State *L, const char *what, long long cost) {
    sm_scene *s = sc_scene_of(L);
    if (s->tripped) trip(L, s, "", "");
    if (cost < 0) cost = 0;
    int over = cost > s->insn_limit - s->insn;
    s->insn = over ? s->insn_limit + 1 : s->insn + cost;
    int late = over ? 0 : out_of_time(s);
    if (!over && !late) return;
    luaL_where(L, 1); /* the scene code that called the library function */
    const char *where = lua_tostring(L, -1);
    if (late) over_time(L, s, where, late);
    char msg[256];
    snprintf(msg, sizeof msg,
             "%s: instruction limit exceeded (%d million Lua instructions, the work inside library functions "
             "counted too): too much work for a scene",
             what, (int)(s->insn_limit / 1000000));
    trip(L, s, where, msg);
}

void sc_set_budget(sm_scene *s, long long limit, double seconds, const char *what) {
    s->insn = 0;
    s->next_clock = CLOCK_EVERY;
    s->insn_limit = limit;
    s->time_limit = seconds;
    s->budget_what = what;
    s->cpu_start = clock_seconds(CLOCK_THREAD_CPUTIME_ID);
    s->wall_start = clock_seconds(CLOCK_MONOTONIC);
    s->tripped = 0;
    s->trip_msg[0] = 0;
    s->hooks_on = 1;
    s->hook_every = HOOK_STEP;
    lua_sethook(s->L, insn_hook, LUA_MASKCOUNT, HOOK_STEP);
}

/* After a protected call failed: the limit's message again if the scene is tripped. */
static void reraise_if_tripped(lua_State *L) {
    sm_scene *s = sc_scene_of(L);
    if (s->tripped) trip(L, s, "", "");
}

/* The results of pcall and xpcall after lua_pcall returned st: true and the values from index
 * slot + 1 on (slot is a spare stack slot below them), or false and the message (re-raised if the
 * scene is tripped). */
static int protected_results(lua_State *L, int st, int slot) {
    if (st != LUA_OK) {
        reraise_if_tripped(L);
        lua_pushboolean(L, 0);
        lua_insert(L, -2);
        return 2;
    }
    lua_pushboolean(L, 1);
    lua_replace(L, slot);
    return lua_gettop(L) - slot + 1;
}

static int scene_pcall(lua_State *L) { /* pcall(f, ...) -> true, results | false, message */
    luaL_checkany(L, 1);
    lua_pushnil(L);
    lua_insert(L, 1); /* the slot for true */
    return protected_results(L, lua_pcall(L, lua_gettop(L) - 2, LUA_MULTRET, 0), 1);
}

/* xpcall's message handler, guarded: the scene's handler (upvalue 1) runs only while the scene is
 * not tripped. */
static int guarded_handler(lua_State *L) {
    if (sc_scene_of(L)->tripped) return 1; /* the message as it is */
    lua_pushvalue(L, lua_upvalueindex(1));
    lua_insert(L, 1);
    lua_call(L, lua_gettop(L) - 1, 1);
    return 1;
}

static int scene_xpcall(lua_State *L) { /* xpcall(f, handler, ...) */
    luaL_checktype(L, 2, LUA_TFUNCTION);
    int n = lua_gettop(L);
    lua_pushvalue(L, 2);
    lua_pushcclosure(L, guarded_handler, 1);
    lua_replace(L, 2);     /* f, guard, args... */
    lua_pushvalue(L, 1);   /* f, guard, args..., f */
    lua_rotate(L, 3, 1);   /* f, guard, f, args... */
    return protected_results(L, lua_pcall(L, n - 2, LUA_MULTRET, 2), 2);
}

/* collectgarbage: only "count" and "collect" (the default); stopping or tuning the collector is
 * not a scene's business. */
static int scene_collectgarbage(lua_State *L) {
    const char *opt = luaL_optstring(L, 1, "collect");
    if (!strcmp(opt, "count")) {
        lua_pushnumber(L, (lua_Number)lua_gc(L, LUA_GCCOUNT) + (lua_Number)lua_gc(L, LUA_GCCOUNTB) / 1024);
        return 1;
    }
    if (!strcmp(opt, "collect")) {
        lua_gc(L, LUA_GCCOLLECT);
        lua_pushinteger(L, 0);
        return 1;
    }
    return luaL_error(L, "collectgarbage(\"%s\") is not available in scene files (only \"count\" and \"collect\")",
                      opt);
}

static const char *const forbidden[] = {"io", "os", "package", "require", "debug", "dofile", "loadfile", "load",
                                        "loadstring", "coroutine", "module"};

static int globals_index(lua_State *L) {
    const char *k = lua_type(L, 2) == LUA_TSTRING ? lua_tostring(L, 2) : NULL;
    if (k)
        for (size_t i = 0; i < sizeof forbidden / sizeof forbidden[0]; i++)
            if (!strcmp(k, forbidden[i]))
                return luaL_error(L, "%s is not available in scene files (they run in a sandbox: math, string and "
                                     "table only, no files or OS access)", k);
    return 0;
}

/* setmetatable without __gc: Lua runs finalizers with hooks off, so the instruction limit could not
 * stop one (and an object is only finalized if its metatable had __gc when it was set). */
static int scene_setmetatable(lua_State *L) { /* lbaselib.c's, plus the __gc check */
    int t = lua_type(L, 2);
    luaL_checktype(L, 1, LUA_TTABLE);
    luaL_argexpected(L, t == LUA_TNIL || t == LUA_TTABLE, 2, "nil or table");
    if (t == LUA_TTABLE) {
        lua_pushliteral(L, "__gc");
        if (lua_rawget(L, 2) != LUA_TNIL) return luaL_error(L, "__gc metamethods are not allowed in scene files");
        lua_pop(L, 1);
    }
    if (luaL_getmetafield(L, 1, "__metatable") != LUA_TNIL) return luaL_error(L, "cannot change a protected metatable");
    lua_settop(L, 2);
    lua_setmetatable(L, 1);
    return 1;
}

static int not_available(lua_State *L) {
    return luaL_error(L, "string.%s is not available in scene files (they run in a sandbox)",
                      lua_tostring(L, lua_upvalueindex(1)));
}

/* The string table: dump, pack and unpack removed (binary data is not a scene's business); the
 * string metatable hidden from getmetatable (scenes cannot change what ("x"):f() calls). */
static void restrict_strings(lua_State *L) {
    lua_getglobal(L, LUA_STRLIBNAME);
    const char *gone[] = {"dump", "pack", "unpack", "packsize"};
    for (int i = 0; i < 4; i++) {
        lua_pushstring(L, gone[i]);
        lua_pushcclosure(L, not_available, 1);
        lua_setfield(L, -2, gone[i]);
    }
    lua_pop(L, 1);
    lua_pushliteral(L, "");
    lua_getmetatable(L, -1);
    lua_pushboolean(L, 0);
    lua_setfield(L, -2, "__metatable");
    lua_pop(L, 2);
}

/* Runs protected: opens the allowed libraries and sets up the globals. */
int sc_sandbox_init(lua_State *L) {
    luaL_requiref(L, LUA_GNAME, luaopen_base, 1);
    luaL_requiref(L, LUA_MATHLIBNAME, luaopen_math, 1);
    luaL_requiref(L, LUA_STRLIBNAME, luaopen_string, 1);
    luaL_requiref(L, LUA_TABLIBNAME, luaopen_table, 1);
    luaL_requiref(L, LUA_UTF8LIBNAME, luaopen_utf8, 1);
    lua_settop(L, 0);
    for (size_t i = 0; i < sizeof forbidden / sizeof forbidden[0]; i++) {
        lua_pushnil(L);
        lua_setglobal(L, forbidden[i]);
    }
    /* Lua 5.4 seeds math.random from the clock: make scenes that use it reproducible. */
    lua_getglobal(L, LUA_MATHLIBNAME);
    lua_getfield(L, -1, "randomseed");
    lua_pushinteger(L, 1);
    lua_call(L, 1, 0);
    lua_pop(L, 1);
    restrict_strings(L);
    sc_open_bounded(L);
    sc_open_patterns(L);
    const luaL_Reg base[] = {{"setmetatable", scene_setmetatable}, {"pcall", scene_pcall}, {"xpcall", scene_xpcall},
                             {"collectgarbage", scene_collectgarbage}, {NULL, NULL}};
    lua_pushglobaltable(L);
    luaL_setfuncs(L, base, 0);
    /* _G's metatable: clear messages for the removed libraries. */
    lua_createtable(L, 0, 2);
    lua_pushcfunction(L, globals_index);
    lua_setfield(L, -2, "__index");
    lua_pushboolean(L, 0);
    lua_setfield(L, -2, "__metatable");
    lua_setmetatable(L, -2);
    lua_pop(L, 1);
    sc_open_scene_globals(L);
    lua_settop(L, 0);
    return 0;
}

/* The message of a failed pcall (top of the stack), popped, into buf. */
void sc_pop_error(lua_State *L, int status, char *buf, size_t n) {
    sm_scene *s = sc_scene_of(L);
    if (status == LUA_ERRMEM) {
        if (s->mem_hit) snprintf(buf, n, "memory limit exceeded (%zu MB of Lua memory)", s->mem_limit >> 20);
        else snprintf(buf, n, "out of memory");
    } else if (lua_type(L, -1) == LUA_TSTRING || lua_type(L, -1) == LUA_TNUMBER) {
        sc_copy_str(buf, n, lua_tostring(L, -1));
    } else {
        snprintf(buf, n, "(error object is a %s value)", luaL_typename(L, -1));
    }
    lua_pop(L, 1);
}

/* Does msg already start with Lua's "chunk:line:" position? */
int sc_has_position(const char *msg) {
    const char *c = strchr(msg, ':');
    while (c) {
        const char *d = c + 1;
        if (isdigit((unsigned char)*d)) {
            while (isdigit((unsigned char)*d)) d++;
            if (*d == ':') return 1;
        }
        if (c - msg > 512) break;
        c = strchr(c + 1, ':');
    }
    return 0;
}

lua_State *sc_sandbox_new(sm_scene *s) {
    lua_State *L = lua_newstate(scene_alloc, s);
    if (L) *(sm_scene **)lua_getextraspace(L) = s;
    return L;
}
