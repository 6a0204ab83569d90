// gl_test_context.h — the one OSMesa context of a test process, created on first use.
#pragma once

#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "tessref/error.h"
#include "tessref/gl_backend.h"

// Never destroyed: destroying a context from a static destructor at exit, after draws of
// gl::evaluate, crashed inside OSMesaDestroyContext (Mesa's own teardown has run by then);
// the process's end frees it. A test that gets no context fails, with the reason.
inline tessref::gl::Context* gl_test_context() {
    static tessref::gl::Context* ctx = nullptr;
    static std::string failure;
    if (!ctx && failure.empty()) {
        try {
            ctx = new tessref::gl::Context(tessref::gl::Context::create());
            std::printf("[ gl       ] %s | %s\n", ctx->renderer().c_str(), ctx->version().c_str());
        } catch (const tessref::Error& e) {
            failure = e.message();
        }
    }
    if (!ctx) ADD_FAILURE() << "no OSMesa OpenGL 4.5 context: " << failure;
    return ctx;
}
