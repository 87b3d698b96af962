!> Values by name: what a caller hands the core and what it reads back, in
!> place of long positional argument lists.  A named_t holds numbers (real
!> or integer, of any shape up to three dimensions, kept in Fortran order)
!> and texts, each under its name.  Reading a name that is missing, of the
!> other kind or of another shape is a message naming it.
module mlid_named
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: itoa
  implicit none
  private
  public :: named_t, value_t, VALUE_REAL, VALUE_INT, VALUE_TEXT, VALUE_KIND_NAMES, MAXRANK

  integer, parameter :: VALUE_REAL = 1, VALUE_INT = 2, VALUE_TEXT = 3
  !> Their names, one a line in the order of the codes (for the front ends).
  character(len=*), parameter :: VALUE_KIND_NAMES = 'real'//achar(10)//'integer'//achar(10)// &
                                                    'text'//achar(10)
  integer, parameter :: MAXRANK = 3

  type :: value_t
    character(len=:), allocatable :: name
    integer :: kind = 0
    integer :: rank = 0
    integer :: shape(MAXRANK) = 1
    real(wp), allocatable :: r(:)
    integer, allocatable :: i(:)
    character(len=:), allocatable :: t
  end type value_t

  type :: named_t
    type(value_t), allocatable :: v(:)   !< v(1:n) hold values; the rest is room
    integer :: n = 0
  contains
    procedure :: find, has, names, clear
    procedure :: put_value, put_real0, put_real1, put_real2, put_real3, put_int0, put_int1, &
                 put_int2, put_text, put_logical
    generic :: put => put_real0, put_real1, put_real2, put_real3, put_int0, put_int1, put_int2, &
                      put_text, put_logical
    procedure :: get_real0, get_real1, get_real2, get_real3, get_int0, get_int1, get_int2, &
                 get_text
    generic :: get => get_real0, get_real1, get_real2, get_real3, get_int0, get_int1, get_int2, &
                      get_text
  end type named_t

contains

  !> Index of name (0: none).
  integer function find(self, name)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    integer :: k, m
    find = 0
    m = len_trim(name)
    do k = 1, self%n
      if (self%v(k)%name == name(1:m)) then
        find = k
        return
      end if
    end do
  end function find

  logical function has(self, name)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    has = self%find(name) > 0
  end function has

  !> The names held, one a line, in the order they were first put.
  function names(self) result(text)
    class(named_t), intent(in) :: self
    character(len=:), allocatable :: text
    integer :: k
    text = ''
    do k = 1, self%n
      text = text//self%v(k)%name//achar(10)
    end do
  end function names

  subroutine clear(self)
    class(named_t), intent(inout) :: self
    if (allocated(self%v)) deallocate (self%v)
    self%n = 0
  end subroutine clear

  !> Put v under its name, replacing what was there; v is moved in (it is
  !> empty after).  Room doubles as it fills.
  subroutine put_value(self, v)
    class(named_t), intent(inout) :: self
    type(value_t), intent(inout) :: v
    type(value_t), allocatable :: more(:)
    integer :: k
    k = self%find(v%name)
    if (k > 0) then
      call move_value(v, self%v(k))
      return
    end if
    if (.not. allocated(self%v)) allocate (self%v(16))
    if (self%n == size(self%v)) then
      allocate (more(2*self%n))
      do k = 1, self%n
        call move_value(self%v(k), more(k))
      end do
      call move_alloc(more, self%v)
    end if
    self%n = self%n + 1
    call move_value(v, self%v(self%n))
  end subroutine put_value

  !> Moved whole, component by component (no deep copy of the arrays).
  subroutine move_value(from, to)
    type(value_t), intent(inout) :: from
    type(value_t), intent(out) :: to
    call move_alloc(from%name, to%name)
    to%kind = from%kind
    to%rank = from%rank
    to%shape = from%shape
    if (allocated(from%r)) call move_alloc(from%r, to%r)
    if (allocated(from%i)) call move_alloc(from%i, to%i)
    if (allocated(from%t)) call move_alloc(from%t, to%t)
  end subroutine move_value

  function numbers(name, kind, shp) result(v)
    character(len=*), intent(in) :: name
    integer, intent(in) :: kind, shp(:)
    type(value_t) :: v
    v%name = trim(name)
    v%kind = kind
    v%rank = size(shp)
    v%shape = 1
    v%shape(1:size(shp)) = shp
  end function numbers

  subroutine put_real0(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    real(wp), intent(in) :: x
    type(value_t) :: v
    v = numbers(name, VALUE_REAL, [integer ::])
    v%r = [x]
    call self%put_value(v)
  end subroutine put_real0

  subroutine put_real1(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    real(wp), intent(in) :: x(:)
    type(value_t) :: v
    v = numbers(name, VALUE_REAL, shape(x))
    v%r = x
    call self%put_value(v)
  end subroutine put_real1

  subroutine put_real2(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    real(wp), intent(in) :: x(:, :)
    type(value_t) :: v
    v = numbers(name, VALUE_REAL, shape(x))
    v%r = reshape(x, [size(x)])
    call self%put_value(v)
  end subroutine put_real2

  subroutine put_real3(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    real(wp), intent(in) :: x(:, :, :)
    type(value_t) :: v
    v = numbers(name, VALUE_REAL, shape(x))
    v%r = reshape(x, [size(x)])
    call self%put_value(v)
  end subroutine put_real3

  subroutine put_int0(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    integer, intent(in) :: x
    type(value_t) :: v
    v = numbers(name, VALUE_INT, [integer ::])
    v%i = [x]
    call self%put_value(v)
  end subroutine put_int0

  subroutine put_int1(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    integer, intent(in) :: x(:)
    type(value_t) :: v
    v = numbers(name, VALUE_INT, shape(x))
    v%i = x
    call self%put_value(v)
  end subroutine put_int1

  subroutine put_int2(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    integer, intent(in) :: x(:, :)
    type(value_t) :: v
    v = numbers(name, VALUE_INT, shape(x))
    v%i = reshape(x, [size(x)])
    call self%put_value(v)
  end subroutine put_int2

  subroutine put_logical(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    logical, intent(in) :: x
    call self%put_int0(name, merge(1, 0, x))
  end subroutine put_logical

  subroutine put_text(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    character(len=*), intent(in) :: x
    type(value_t) :: v
    v%name = trim(name)
    v%kind = VALUE_TEXT
    v%t = x
    call self%put_value(v)
  end subroutine put_text

  !> The value called name, of kind and rank (an integer is read as a real
  !> too); status and a message naming it when it is not.
  subroutine take(self, name, kind, rank, k, status, msg)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    integer, intent(in) :: kind, rank
    integer, intent(out) :: k, status
    character(len=*), intent(out) :: msg
    character(len=*), parameter :: KINDS(3) = [character(len=7) :: 'real', 'integer', 'text']
    status = MLID_ERR_INPUT
    msg = ''
    k = self%find(name)
    if (k == 0) then
      msg = 'no value '''//trim(name)//''' given'
      return
    end if
    associate (v => self%v(k))
      if (.not. (v%kind == kind .or. (kind == VALUE_REAL .and. v%kind == VALUE_INT))) then
        msg = trim(name)//' must be '//trim(KINDS(kind))//', not '//trim(KINDS(v%kind))
        return
      end if
      ! a single number is also a 0-d array, and a scalar a vector of one
      if (kind /= VALUE_TEXT .and. v%rank /= rank .and. .not. (rank == 0 .and. &
          product(v%shape) == 1) .and. .not. (rank == 1 .and. v%rank == 0)) then
        msg = trim(name)//' must have '//itoa(rank)//' dimensions, not '//itoa(v%rank)
        return
      end if
    end associate
    status = MLID_OK
  end subroutine take

  function reals(v) result(x)
    type(value_t), intent(in) :: v
    real(wp), allocatable :: x(:)
    if (v%kind == VALUE_INT) then
      x = real(v%i, wp)
    else
      x = v%r
    end if
  end function reals

  subroutine get_real0(self, name, x, status, msg)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    real(wp), intent(out) :: x
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: all(:)
    integer :: k
    x = 0.0_wp
    call take(self, name, VALUE_REAL, 0, k, status, msg)
    if (status /= MLID_OK) return
    all = reals(self%v(k))
    x = all(1)
  end subroutine get_real0

  subroutine get_real1(self, name, x, status, msg)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    real(wp), allocatable, intent(out) :: x(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k
    call take(self, name, VALUE_REAL, 1, k, status, msg)
    if (status /= MLID_OK) return
    x = reals(self%v(k))
  end subroutine get_real1

  subroutine get_real2(self, name, x, status, msg)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    real(wp), allocatable, intent(out) :: x(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k
    call take(self, name, VALUE_REAL, 2, k, status, msg)
    if (status /= MLID_OK) return
    x = reshape(reals(self%v(k)), self%v(k)%shape(1:2))
  end subroutine get_real2

  subroutine get_real3(self, name, x, status, msg)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    real(wp), allocatable, intent(out) :: x(:, :, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k
    call take(self, name, VALUE_REAL, 3, k, status, msg)
    if (status /= MLID_OK) return
    x = reshape(reals(self%v(k)), self%v(k)%shape(1:3))
  end subroutine get_real3

  subroutine get_int0(self, name, x, status, msg)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    integer, intent(out) :: x
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k
    x = 0
    call take(self, name, VALUE_INT, 0, k, status, msg)
    if (status == MLID_OK) x = self%v(k)%i(1)
  end subroutine get_int0

  subroutine get_int1(self, name, x, status, msg)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    integer, allocatable, intent(out) :: x(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k
    call take(self, name, VALUE_INT, 1, k, status, msg)
    if (status == MLID_OK) x = self%v(k)%i
  end subroutine get_int1

  subroutine get_int2(self, name, x, status, msg)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    integer, allocatable, intent(out) :: x(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k
    call take(self, name, VALUE_INT, 2, k, status, msg)
    if (status == MLID_OK) x = reshape(self%v(k)%i, self%v(k)%shape(1:2))
  end subroutine get_int2

  subroutine get_text(self, name, x, status, msg)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    character(len=:), allocatable, intent(out) :: x
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k
    x = ''
    call take(self, name, VALUE_TEXT, 0, k, status, msg)
    if (status == MLID_OK) x = self%v(k)%t
  end subroutine get_text

end module mlid_named
