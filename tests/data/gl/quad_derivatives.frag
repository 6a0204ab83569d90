#version 450 core
// dFdx and dFdy of floor(x) * floor(y) of the window position: in a 2x2 quad, per row and
// per column, floor(y) and floor(x) of the fragment's own row and column (fine), signed
// with window y growing upwards. Each channel an integer below 256 over 255, so that the
// 8-bit picture holds it exactly; blue 1 marks a drawn pixel.
layout(location = 0) out vec4 outputColor;

void main()
{
    float v = floor(gl_FragCoord.x) * floor(gl_FragCoord.y);
    outputColor = vec4(mod(dFdx(v), 256.0) / 255.0, mod(dFdy(v), 256.0) / 255.0, 1.0, 1.0);
}
