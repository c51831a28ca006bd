"""CPU stage of the frame: numpy in, numpy GPU-layout arrays out.  No OpenGL here."""
