"""Records (see `..ir`) -> USD. pxr only: nothing here imports bpy."""
