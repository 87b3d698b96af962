!> The MAT-file reader (mlid_matfile through mlid_tablefile) on files this
!> test writes byte by byte: a matrix beside a char array (passed over);
!> vectors of double, int16 and uint8 (its values in a small data element)
!> beside a cell and a complex array (passed over); each little-endian,
!> big-endian and compressed, all giving one table.  Every cut of a file
!> short of its end, a garbage header, a part longer than its matrix and
!> damaged zlib data each give a status and one line naming the file;
!> threads reading the files at once get the tables one thread gets.
program test_matfile
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_int8_t
  use, intrinsic :: iso_fortran_env, only: int8, int16, int32, int64
  use mlid_kinds, only: wp, MLID_OK
  use mlid_tablefile, only: tablefile_read
  use test_checks, only: check, finish
  implicit none

  interface
    function compress(dest, destlen, source, sourcelen) bind(c, name='compress') result(rc)
      import :: c_int, c_long, c_int8_t
      integer(c_int8_t), intent(inout) :: dest(*)
      integer(c_long), intent(inout) :: destlen
      integer(c_int8_t), intent(in) :: source(*)
      integer(c_long), value, intent(in) :: sourcelen
      integer(c_int) :: rc
    end function compress
  end interface

  type :: table_t
    real(wp), allocatable :: x(:, :)
    character(len=32), allocatable :: names(:), units(:)
    integer :: status = -1
    character(len=256) :: msg = ''
  end type table_t

  integer, parameter :: MI_UINT8 = 2, MI_INT16 = 3, MI_UINT16 = 4, MI_INT32 = 5, MI_UINT32 = 6, &
                        MI_DOUBLE = 9, MI_MATRIX = 14
  character(len=*), parameter :: DIR = 'test_matfile_'
  real(wp), parameter :: REC(3, 2) = reshape([1.5_wp, -2.0_wp, 3.25_wp, 4.0_wp, 5.0_wp, &
                                              -6.5e-300_wp], [3, 2])
  real(wp), parameter :: T(4) = [0.0_wp, 0.1_wp, 0.2_wp, 0.3_wp], &
                         Y(4) = [-3.0_wp, 0.0_wp, 7.0_wp, 30000.0_wp], &
                         Z(4) = [0.0_wp, 1.0_wp, 200.0_wp, 255.0_wp]
  character(len=64) :: files(6)
  type(table_t) :: tab(6), again
  integer(int8), allocatable :: a_le(:)
  integer :: k, m, bad

  do k = 0, 1
    call save(trim(DIR)//'a'//merge('be', 'le', k == 1)//'.mat', file_a(k == 1, .false.))
    call save(trim(DIR)//'b'//merge('be', 'le', k == 1)//'.mat', file_b(k == 1, .false.))
  end do
  call save(trim(DIR)//'ac.mat', file_a(.false., .true.))
  call save(trim(DIR)//'bc.mat', file_b(.false., .true.))
  files = [character(len=64) :: 'ale', 'abe', 'ac', 'ble', 'bbe', 'bc']
  do k = 1, 6
    files(k) = trim(DIR)//trim(files(k))//'.mat'
    tab(k) = table_of(files(k))
    call check(tab(k)%status == MLID_OK, trim(files(k))//' is read: '//trim(tab(k)%msg))
  end do
  if (tab(1)%status == MLID_OK) then
    call check(all(shape(tab(1)%x) == [3, 2]) .and. all(tab(1)%x == REC), &
               'the matrix is the table, the char array passed over')
    call check(all(tab(1)%names == '') .and. all(tab(1)%units == ''), 'its columns are unnamed')
  end if
  if (tab(4)%status == MLID_OK) then
    call check(all(shape(tab(4)%x) == [4, 3]), 'three vectors (cell and complex passed over)')
    call check(all(tab(4)%x(:, 1) == T) .and. all(tab(4)%x(:, 2) == Y) .and. &
               all(tab(4)%x(:, 3) == Z), 'double, int16 and uint8 (small element) values')
    call check(all(tab(4)%names == ['t', 'y', 'z']), 'named by their variables, in file order')
  end if
  do k = 1, 6
    m = merge(1, 4, k <= 3)
    call check(same(tab(k), tab(m)), trim(files(k))//' gives the table of '//trim(files(m)))
  end do

  call cuts(trim(DIR)//'ac.mat')
  call cuts(trim(DIR)//'ble.mat')
  a_le = file_a(.false., .false.)
  call refused('garbage header', [a_le(1:120), int([(65 + k, k=1, 8)], int8), a_le(129:)], &
               'not a MATLAB file')
  call refused('a real part longer than its matrix', longer_part(a_le), 'real part')
  call refused('damaged zlib data', damaged(file_a(.false., .true.)), 'zlib')

  bad = 0
  !$omp parallel do private(again) reduction(+:bad) schedule(dynamic)
  do k = 1, 240
    again = table_of(files(mod(k, 6) + 1))
    if (.not. same(again, tab(mod(k, 6) + 1))) bad = bad + 1
  end do
  !$omp end parallel do
  call check(bad == 0, 'threads reading at once get the tables one thread gets')
  call finish()

contains

  function table_of(path) result(tb)
    character(len=*), intent(in) :: path
    type(table_t) :: tb
    call tablefile_read(path, '', tb%x, tb%names, tb%units, tb%status, tb%msg)
  end function table_of

  logical function same(a, b)
    type(table_t), intent(in) :: a, b
    same = a%status == MLID_OK .and. b%status == MLID_OK
    if (.not. same) return
    same = all(shape(a%x) == shape(b%x)) .and. size(a%names) == size(b%names)
    if (same) same = all(a%x == b%x) .and. all(a%names == b%names) .and. all(a%units == b%units)
  end function same

  !> Every cut of path short of its end: refused, one line naming the
  !> file, unless the cut falls between elements (a shorter file, as good).
  subroutine cuts(path)
    character(len=*), intent(in) :: path
    integer(int8), allocatable :: b(:)
    type(table_t) :: tb
    integer :: n, wrong, u
    open (newunit=u, file=path, access='stream', form='unformatted', action='read')
    allocate (b(size_of(u)))
    read (u) b
    close (u)
    wrong = 0
    do n = 0, size(b) - 1
      call save(trim(DIR)//'cut.mat', b(1:n))
      tb = table_of(trim(DIR)//'cut.mat')
      if (tb%status == MLID_OK .and. .not. boundary(b, n)) wrong = wrong + 1
      if (tb%status /= MLID_OK .and. (index(tb%msg, 'data file '//trim(DIR)//'cut.mat: ') /= 1 &
          .or. index(tb%msg, achar(10)) > 0)) wrong = wrong + 1
    end do
    call check(wrong == 0, path//' cut at each of its lengths: refused with one line')
  end subroutine cuts

  !> Whether n bytes of a MAT-file b end between its elements.
  logical function boundary(b, n)
    integer(int8), intent(in) :: b(:)
    integer, intent(in) :: n
    integer :: p
    p = 128
    boundary = .false.
    do while (p < n)
      p = p + 8 + int(transfer(b(p + 5:p + 8), 0_int32))
    end do
    boundary = p == n
  end function boundary

  integer function size_of(u)
    integer, intent(in) :: u
    inquire (unit=u, size=size_of)
  end function size_of

  subroutine refused(what, bytes, words)
    character(len=*), intent(in) :: what, words
    integer(int8), intent(in) :: bytes(:)
    type(table_t) :: tb
    call save(trim(DIR)//'bad.mat', bytes)
    tb = table_of(trim(DIR)//'bad.mat')
    call check(tb%status /= MLID_OK .and. index(tb%msg, words) > 0 .and. &
               index(tb%msg, 'data file '//trim(DIR)//'bad.mat: ') == 1, &
               what//' refused: '//trim(tb%msg))
  end subroutine refused

  !> File a with its matrix's real part claiming 8 bytes more.
  function longer_part(a) result(b)
    integer(int8), intent(in) :: a(:)
    integer(int8), allocatable :: b(:)
    integer :: p
    b = a
    p = 128 + 8 + 16 + 16 + 8            ! tag, flags, dims (2), name 'rec' (small)
    b(p + 5:p + 8) = transfer(transfer(b(p + 5:p + 8), 0_int32) + 8_int32, [0_int8])
  end function longer_part

  !> A compressed file with bytes in the middle of its first stream changed.
  function damaged(a) result(b)
    integer(int8), intent(in) :: a(:)
    integer(int8), allocatable :: b(:)
    b = a
    b(128 + 8 + 6:128 + 8 + 12) = not(b(128 + 8 + 6:128 + 8 + 12))
  end function damaged

  subroutine save(path, bytes)
    character(len=*), intent(in) :: path
    integer(int8), intent(in) :: bytes(:)
    integer :: u
    open (newunit=u, file=path, access='stream', form='unformatted', status='replace', &
          action='write')
    write (u) bytes
    close (u)
  end subroutine save

  !> The matrix rec (3 x 2 doubles) and the char array note.
  function file_a(big, packed) result(b)
    logical, intent(in) :: big, packed
    integer(int8), allocatable :: b(:)
    b = [header(big), &
         element(matrix(6, 0, [3, 2], 'rec', MI_DOUBLE, encode(pack(REC, .true.), MI_DOUBLE, &
                        big), big), big, packed), &
         element(matrix(4, 0, [1, 5], 'note', MI_UINT16, encode(real([104, 101, 108, 108, 111], &
                        wp), MI_UINT16, big), big), big, packed)]
  end function file_a

  !> The vectors t (double), y (int16), z (uint8), the cell c, the complex q.
  function file_b(big, packed) result(b)
    logical, intent(in) :: big, packed
    integer(int8), allocatable :: b(:)
    integer(int8), allocatable :: q(:)
    allocate (q(0))                    ! (gfortran 12 warns of a descriptor otherwise)
    q = matrix(6, 2048, [1, 4], 'q', MI_DOUBLE, encode(T, MI_DOUBLE, big), big)
    q = [q, part(MI_DOUBLE, encode(Y, MI_DOUBLE, big), big)]       ! its imaginary part
    b = [header(big), &
         element(matrix(6, 0, [1, 4], 't', MI_DOUBLE, encode(T, MI_DOUBLE, big), big), big, &
                 packed), &
         element(matrix(6, 0, [4, 1], 'y', MI_INT16, encode(Y, MI_INT16, big), big), big, packed), &
         element(matrix(9, 0, [1, 4], 'z', MI_UINT8, encode(Z, MI_UINT8, big), big), big, packed), &
         element(cell('c', matrix(6, 0, [1, 1], '', MI_DOUBLE, encode([42.0_wp], MI_DOUBLE, &
                                  big), big), big), big, packed), &
         element(q, big, packed)]
  end function file_b

  !> The parts of a 1 x 1 cell named name holding the matrix of parts inner.
  function cell(name, inner, big) result(b)
    character(len=*), intent(in) :: name
    integer(int8), intent(in) :: inner(:)
    logical, intent(in) :: big
    integer(int8), allocatable :: b(:)
    b = [head(1, 0, [1, 1], name, big), word(MI_MATRIX, big), word(size(inner), big), inner]
  end function cell

  function header(big) result(b)
    logical, intent(in) :: big
    integer(int8), allocatable :: b(:)
    character(len=116) :: text
    text = 'MATLAB 5.0 MAT-file, written by test_matfile'
    b = [transfer(text, [0_int8]), spread(0_int8, 1, 8)]
    if (big) then
      b = [b, int([1, 0], int8), transfer('MI', [0_int8])]
    else
      b = [b, int([0, 1], int8), transfer('IM', [0_int8])]
    end if
  end function header

  !> A top-level element: the matrix's tag and parts, or all of it
  !> compressed (miCOMPRESSED, not padded).
  function element(parts, big, packed) result(b)
    integer(int8), intent(in) :: parts(:)
    logical, intent(in) :: big, packed
    integer(int8), allocatable :: b(:), whole(:), z(:)
    integer(c_long) :: zlen
    allocate (whole(8 + size(parts)))
    whole(1:4) = word(MI_MATRIX, big)
    whole(5:8) = word(size(parts), big)
    whole(9:) = parts
    if (.not. packed) then
      b = whole
      return
    end if
    allocate (z(2*size(whole) + 64))
    zlen = size(z)
    if (compress(z, zlen, whole, int(size(whole), c_long)) /= 0) error stop 'compress failed'
    b = [word(15, big), word(int(zlen), big), z(1:zlen)]
  end function element

  !> The parts of a matrix: flags, dimensions, name (head), the real part
  !> (a small element when 4 bytes or fewer).
  function matrix(cls, flag_bits, dims, name, typ, data, big) result(b)
    integer, intent(in) :: cls, flag_bits, dims(:), typ
    character(len=*), intent(in) :: name
    integer(int8), intent(in) :: data(:)
    logical, intent(in) :: big
    integer(int8), allocatable :: b(:)
    b = [head(cls, flag_bits, dims, name, big), part(typ, data, big)]
  end function matrix

  !> Flags (class, flag bits), dimensions, and the name (a small element
  !> when 1 to 4 bytes).
  function head(cls, flag_bits, dims, name, big) result(b)
    integer, intent(in) :: cls, flag_bits, dims(:)
    character(len=*), intent(in) :: name
    logical, intent(in) :: big
    integer(int8), allocatable :: b(:)
    integer :: j
    b = [word(MI_UINT32, big), word(8, big), word(cls + flag_bits, big), word(0, big), &
         word(MI_INT32, big), word(4*size(dims), big), [(word(dims(j), big), j=1, size(dims))]]
    b = [padded(b), part(1, transfer(name, [0_int8], len(name)), big)]
  end function head

  function part(typ, data, big) result(b)
    integer, intent(in) :: typ
    integer(int8), intent(in) :: data(:)
    logical, intent(in) :: big
    integer(int8), allocatable :: b(:)
    if (size(data) >= 1 .and. size(data) <= 4) then
      b = [word(typ + 65536*size(data), big), data, spread(0_int8, 1, 4 - size(data))]
    else
      b = padded([word(typ, big), word(size(data), big), data])
    end if
  end function part

  function padded(a) result(b)
    integer(int8), intent(in) :: a(:)
    integer(int8), allocatable :: b(:)
    b = [a, spread(0_int8, 1, modulo(-size(a), 8))]
  end function padded

  function word(v, big) result(b)
    integer, intent(in) :: v
    logical, intent(in) :: big
    integer(int8) :: b(4)
    b = transfer(int(v, int32), b)
    if (big) b = b(4:1:-1)
  end function word

  !> Values as type typ, in the file's byte order.
  function encode(v, typ, big) result(b)
    real(wp), intent(in) :: v(:)
    integer, intent(in) :: typ
    logical, intent(in) :: big
    integer(int8), allocatable :: b(:), one(:)
    integer :: j
    allocate (b(0))
    do j = 1, size(v)
      select case (typ)
      case (MI_DOUBLE)
        one = transfer(v(j), [0_int8])
      case (MI_INT16, MI_UINT16)
        one = transfer(int(v(j), int16), [0_int8])
      case (MI_UINT8)
        one = [int(int(v(j)) - merge(256, 0, v(j) > 127), int8)]
      case default
        one = transfer(int(v(j), int32), [0_int8])
      end select
      if (big) one = one(size(one):1:-1)
      b = [b, one]
    end do
  end function encode

end program test_matfile
