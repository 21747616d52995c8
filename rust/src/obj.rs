//! OBJ loading (tobj): leaves as disks and the bark mesh. (Work in progress.)
