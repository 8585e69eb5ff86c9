/* Library functions that can work long inside one C call, where the instruction hook never runs:
 * each is replaced by a version that first charges what the call will cost to the scene's budget
 * (sc_charge: the instruction limit and the wall clock, see sandbox.c), in units of about one Lua
 * instruction's time:
 *   string.rep(s, n, sep)      n / 8 + result bytes / 256; an empty result returns at once (Lua's
 *                              own loops n times even when there is nothing to copy, so
 *                              string.rep("", 2^50) would never end); a result larger than the
 *                              memory limit fails on its first allocation, as before;
 *   string.format/upper/lower/reverse   string argument bytes / 256;
 *   table.sort(t)              #t log2 #t / 2 (comparisons);
 *   table.concat(t, sep, i, j) (j - i + 1) / 4;   table.move(a, f, e, t)  (e - f + 1) / 2;
 *   table.insert/remove(t, pos)  #t / 2 (the shift);   table.unpack(t, i, j)  j - i + 1.
 * Costs use raw lengths (no __len): they only bound the time, the original function does the work
 * and raises its own argument errors. Pattern matching has its own step-counting matcher
 * (pattern.c). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <string.h>

#include <lua5.4/lauxlib.h>
#include <lua5.4/lua.h>
#include <lua5.4/lualib.h>

#include "app/scene/scene_internal.h"

static int bounded_rep(lua_State *L) {
    size_t l, lsep;
    const char *s = luaL_checklstring(L, 1, &l);
    lua_Integer n = luaL_checkinteger(L, 2);
    const char *sep = luaL_optlstring(L, 3, "", &lsep);
    if (n <= 0 || l + lsep == 0) {
        lua_pushliteral(L, "");
        return 1;
    }
    double total = (double)n * (double)l + (double)(n - 1) * (double)lsep;
    if (!(total < 0x1p62)) return luaL_error(L, "resulting string too large");
    size_t len = (size_t)n * l + (size_t)(n - 1) * lsep;
    luaL_Buffer b;
    char *p = luaL_buffinitsize(L, &b, len); /* past the memory limit this fails at once */
    sc_charge(L, "string.rep", (long long)(n / 8) + (long long)(len / 256));
    for (lua_Integer i = 0; i < n; i++) {
        memcpy(p, s, l);
        p += l;
        if (i + 1 < n && lsep) {
            memcpy(p, sep, lsep);
            p += lsep;
        }
    }
    luaL_pushresultsize(&b, len);
    return 1;
}

/* The raw length of argument idx if it is a table, else 0. */
static long long raw_len(lua_State *L, int idx) {
    return lua_type(L, idx) == LUA_TTABLE ? (long long)lua_rawlen(L, idx) : 0;
}

/* Argument idx as an integer if it is one, else def. */
static long long opt_int(lua_State *L, int idx, long long def) {
    int isnum;
    lua_Integer v = lua_tointegerx(L, idx, &isnum);
    return isnum ? (long long)v : def;
}

/* The number of elements from i to j (0 if none), without overflow. */
static long long span(long long i, long long j) {
    return j < i ? 0 : (long long)fmin((double)j - (double)i + 1, 0x1p62);
}

/* What a call of the wrapped function (its name is upvalue 2) with these arguments costs. */
static long long call_cost(lua_State *L, const char *name) {
    if (!strcmp(name, "sort")) {
        double n = (double)raw_len(L, 1);
        return (long long)(n * ceil(log2(n + 1)) / 2);
    }
    if (!strcmp(name, "concat")) return span(opt_int(L, 3, 1), opt_int(L, 4, raw_len(L, 1))) / 4;
    if (!strcmp(name, "move")) return span(opt_int(L, 2, 1), opt_int(L, 3, 0)) / 2;
    if (!strcmp(name, "insert") || !strcmp(name, "remove")) return raw_len(L, 1) / 2;
    if (!strcmp(name, "unpack")) return span(opt_int(L, 2, 1), opt_int(L, 3, raw_len(L, 1)));
    long long bytes = 0; /* string functions: their string arguments' bytes */
    for (int i = 1; i <= lua_gettop(L); i++)
        if (lua_type(L, i) == LUA_TSTRING) bytes += (long long)lua_rawlen(L, i);
    return bytes / 256;
}

/* Charges the call, then runs the original C function (upvalue 1) on the same arguments. */
static int charged(lua_State *L) {
    char what[48];
    const char *name = lua_tostring(L, lua_upvalueindex(2));
    snprintf(what, sizeof what, "%s", lua_tostring(L, lua_upvalueindex(3)));
    sc_charge(L, what, call_cost(L, name));
    lua_CFunction f = lua_tocfunction(L, lua_upvalueindex(1));
    return f(L);
}

/* Replaces lib.name (on top of the stack: the library table) by its charged version. */
static void wrap(lua_State *L, const char *lib, const char *name) {
    lua_getfield(L, -1, name);
    if (!lua_iscfunction(L, -1)) {
        lua_pop(L, 1);
        return;
    }
    lua_pushstring(L, name);
    lua_pushfstring(L, "%s.%s", lib, name);
    lua_pushcclosure(L, charged, 3);
    lua_setfield(L, -2, name);
}

void sc_open_bounded(lua_State *L) {
    lua_getglobal(L, LUA_STRLIBNAME);
    lua_pushcfunction(L, bounded_rep);
    lua_setfield(L, -2, "rep");
    const char *str_fns[] = {"format", "upper", "lower", "reverse"};
    for (int i = 0; i < 4; i++) wrap(L, LUA_STRLIBNAME, str_fns[i]);
    lua_pop(L, 1);
    lua_getglobal(L, LUA_TABLIBNAME);
    const char *tab_fns[] = {"sort", "concat", "move", "insert", "remove", "unpack"};
    for (int i = 0; i < 6; i++) wrap(L, LUA_TABLIBNAME, tab_fns[i]);
    lua_pop(L, 1);
}
