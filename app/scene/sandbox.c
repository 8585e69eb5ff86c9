/* The scene sandbox: a fresh lua_State per scene with a counting allocator (the memory limit), a
 * count hook (the instruction limit), only the safe libraries, and the globals scenes may use
 * (params, axis_angle, print). See app/scene.h for the limits. */
#define _POSIX_C_SOURCE 200809L
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <lua5.4/lauxlib.h>
#include <lua5.4/lua.h>
#include <lua5.4/lualib.h>

#include "app/scene/scene_internal.h"

#define HOOK_STEP 1000 /* the count hook runs every HOOK_STEP instructions */

sm_scene *sc_scene_of(lua_State *L) { return *(sm_scene **)lua_getextraspace(L); }

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
    return q;
}

static void insn_hook(lua_State *L, lua_Debug *ar) {
    (void)ar;
    sm_scene *s = sc_scene_of(L);
    s->insn += HOOK_STEP;
    if (s->insn > s->insn_limit) {
        /* From now on every instruction fails, so a pcall in the script cannot swallow this. */
        lua_sethook(L, insn_hook, LUA_MASKCOUNT, 1);
        luaL_where(L, 0); /* in a hook, level 0 is the interrupted function */
        lua_pushfstring(L, "instruction limit exceeded (%d million Lua instructions): an endless loop?",
                        (int)(s->insn_limit / 1000000));
        lua_concat(L, 2);
        lua_error(L);
    }
}

void sc_set_budget(sm_scene *s, long long limit) {
    s->insn = 0;
    s->insn_limit = limit;
    lua_sethook(s->L, insn_hook, LUA_MASKCOUNT, HOOK_STEP);
}

static void mark_param_used(sm_scene *s, const char *key) {
    for (int i = 0; i < s->nparams; i++)
        if (!strcmp(s->params[i].key, key)) {
            s->params[i].used = 1;
            return;
        }
    for (int i = 0; i < s->nread; i++)
        if (!strcmp(s->read_keys[i], key)) return;
    if (s->nread == s->read_cap) {
        if (s->read_cap >= 4096) return;
        int cap = s->read_cap ? 2 * s->read_cap : 16;
        char **q = realloc(s->read_keys, (size_t)cap * sizeof *q);
        if (!q) return;
        s->read_keys = q;
        s->read_cap = cap;
    }
    if ((s->read_keys[s->nread] = sc_dup_str(key)) != NULL) s->nread++;
}

/* params: an empty proxy whose metatable records which keys the scene reads. */
static int params_index(lua_State *L) {
    if (lua_type(L, 2) == LUA_TSTRING) mark_param_used(sc_scene_of(L), lua_tostring(L, 2));
    lua_pushvalue(L, 2);
    lua_rawget(L, lua_upvalueindex(1));
    return 1;
}

static int params_newindex(lua_State *L) {
    lua_settop(L, 3);
    lua_pushvalue(L, 2);
    lua_pushvalue(L, 3);
    lua_rawset(L, lua_upvalueindex(1));
    return 0;
}

static int params_next(lua_State *L) {
    luaL_checktype(L, 1, LUA_TTABLE);
    lua_settop(L, 2);
    if (lua_next(L, 1)) return 2;
    lua_pushnil(L);
    return 1;
}

static int params_pairs(lua_State *L) {
    sm_scene *s = sc_scene_of(L);
    for (int i = 0; i < s->nparams; i++) s->params[i].used = 1;
    lua_pushcfunction(L, params_next);
    lua_pushvalue(L, lua_upvalueindex(1));
    lua_pushnil(L);
    return 3;
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

static int forbidden_dump(lua_State *L) {
    return luaL_error(L, "string.dump is not available in scene files (they run in a sandbox)");
}

static int scene_print(lua_State *L) {
    int n = lua_gettop(L);
    for (int i = 1; i <= n; i++) {
        size_t len;
        const char *str = luaL_tolstring(L, i, &len);
        if (i > 1) fputc('\t', stderr);
        fwrite(str, 1, len, stderr);
        lua_pop(L, 1);
    }
    fputc('\n', stderr);
    return 0;
}

static int lua_axis_angle(lua_State *L) {
    double q[4];
    double ax = luaL_checknumber(L, 1), ay = luaL_checknumber(L, 2), az = luaL_checknumber(L, 3),
           deg = luaL_checknumber(L, 4);
    if (!sc_quat_axis_angle(ax, ay, az, deg, q))
        return luaL_error(L, "axis_angle: need a finite non-zero axis and a finite angle");
    lua_createtable(L, 4, 0);
    for (int k = 0; k < 4; k++) {
        lua_pushnumber(L, q[k]);
        lua_rawseti(L, -2, k + 1);
    }
    return 1;
}

/* Runs protected: opens the allowed libraries and sets up the globals. */
int sc_sandbox_init(lua_State *L) {
    sm_scene *s = sc_scene_of(L);
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
    lua_getglobal(L, LUA_STRLIBNAME);
    lua_pushcfunction(L, forbidden_dump);
    lua_setfield(L, -2, "dump");
    lua_pop(L, 1);
    lua_pushcfunction(L, scene_print);
    lua_setglobal(L, "print");
    lua_pushcfunction(L, scene_setmetatable);
    lua_setglobal(L, "setmetatable");
    lua_pushcfunction(L, lua_axis_angle);
    lua_setglobal(L, "axis_angle");
    /* _G's metatable: clear messages for the removed libraries. */
    lua_pushglobaltable(L);
    lua_createtable(L, 0, 2);
    lua_pushcfunction(L, globals_index);
    lua_setfield(L, -2, "__index");
    lua_pushboolean(L, 0);
    lua_setfield(L, -2, "__metatable");
    lua_setmetatable(L, -2);
    lua_pop(L, 1);
    /* params */
    lua_newtable(L); /* storage */
    int storage = lua_gettop(L);
    lua_pushstring(L, s->quality);
    lua_setfield(L, storage, "quality");
    for (int i = 0; i < s->nparams; i++) {
        const char *v = s->params[i].value;
        if (!strcmp(v, "true")) lua_pushboolean(L, 1);
        else if (!strcmp(v, "false")) lua_pushboolean(L, 0);
        else if (lua_stringtonumber(L, v) == 0) lua_pushstring(L, v);
        lua_setfield(L, storage, s->params[i].key);
    }
    lua_newtable(L); /* proxy */
    lua_createtable(L, 0, 4);
    lua_pushvalue(L, storage);
    lua_pushcclosure(L, params_index, 1);
    lua_setfield(L, -2, "__index");
    lua_pushvalue(L, storage);
    lua_pushcclosure(L, params_newindex, 1);
    lua_setfield(L, -2, "__newindex");
    lua_pushvalue(L, storage);
    lua_pushcclosure(L, params_pairs, 1);
    lua_setfield(L, -2, "__pairs");
    lua_setmetatable(L, -2);
    lua_setglobal(L, "params");
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
