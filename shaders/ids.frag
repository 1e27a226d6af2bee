#version 330 core
flat in int v_id;
out int frag;
void main() { frag = v_id; }
