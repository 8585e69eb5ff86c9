/* The scene's own globals: params (an empty proxy whose metatable records which keys the scene
 * reads, so that a --set key it never reads can be reported), axis_angle and print. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <lua5.4/lauxlib.h>
#include <lua5.4/lua.h>

#include "app/scene/scene_internal.h"

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

static int scene_print(lua_State *L) {
    size_t bytes = 0;
    int n = lua_gettop(L);
    for (int i = 1; i <= n; i++) {
        size_t len;
        const char *str = luaL_tolstring(L, i, &len);
        if (i > 1) fputc('\t', stderr);
        fwrite(str, 1, len, stderr);
        bytes += len;
        lua_pop(L, 1);
    }
    fputc('\n', stderr);
    sc_charge(L, "print", (long long)(bytes / 256));
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

/* Sets the globals params, axis_angle and print (the sandbox is open). */
void sc_open_scene_globals(lua_State *L) {
    sm_scene *s = sc_scene_of(L);
    lua_pushcfunction(L, scene_print);
    lua_setglobal(L, "print");
    lua_pushcfunction(L, lua_axis_angle);
    lua_setglobal(L, "axis_angle");
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
}
