// The slot of a material's pattern graph: programs for a material with a node network
// get the code engine/gpu/pattern.py generates in place of this file (it defines
// HAS_PATTERN and pattern_eval); a material without one compiles this, nothing.
